#!/usr/bin/env python3
"""Bit for bit: runs a set of 2D decks with two builds of blockdem and compares their final states.

    python3 scripts/bitwise.py BASE_BINARY NEW_BINARY [--scenes 160] [--backend cpu] [--out DIR]

The decks are examples/*.dat (each CYCLE capped at 1500 cycles) and generated scenes, seeded so
that every run makes the same ones: stacks of bricks (aligned, staggered, lifted a little),
polygons falling on a base, a block SPLIT into pieces, columns of aligned and tilted boxes, with
varied ROUND, FRACTION, stiffness, friction, cohesion and damping (SET OVERLAP ACCEPT lets a
crowded scene run). Each deck runs with both binaries (side by side); their state JSON, less the
provenance (date, commit), and their exit codes must be equal. Prints the decks that differ and
exits 1 if any does. A change meant to be "the same results" (a refactor, a faster path) is
checked so: docs/BENCHMARKS.md, "The rigid settle's cost".
"""
import argparse
import glob
import json
import math
import os
import random
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor


def polygon(cx, cy, r, n, a0):
    return " ".join(f"{cx + r * math.cos(a0 - i * 2 * math.pi / n):.3f},{cy + r * math.sin(a0 - i * 2 * math.pi / n):.3f}" for i in range(n))


def generated(seed):
    """One generated scene (deck text)."""
    R = random.Random(seed)
    kind = seed % 4
    cohesion = f" C={R.choice(['1e3', '1e5'])}" if R.random() < 0.3 else ""
    lines = [
        "START",
        f"PROP MAT=1 DENS=2000 KN={R.choice(['1e8', '1e9', '5e9'])} KS={R.choice(['1e8', '1e9'])} F={R.uniform(0.1, 0.9):.2f}{cohesion}",
        f"ROUND {R.choice(['0.02', '0.05', '0.1'])}",
        f"FRACTION {R.choice(['0.1', '0.2'])}",
        "BLOCK -1 -0.5 -1 0 12 0 12 -0.5",
    ]
    if kind == 0:  # a stack of bricks, aligned or staggered, some lifted a little
        rows, w, h = R.randint(2, 6), R.uniform(0.6, 1.5), R.uniform(0.3, 0.6)
        for j in range(rows):
            x0 = R.choice([0.0, w / 2, R.uniform(0, w)])
            for i in range(R.randint(1, 5)):
                x, y = x0 + i * w, j * h + (0.0 if R.random() < 0.7 else R.uniform(0, 0.01))
                lines.append(f"BLOCK {x:.4f},{y:.4f} {x:.4f},{y + h:.4f} {x + w:.4f},{y + h:.4f} {x + w:.4f},{y:.4f}")
    elif kind == 1:  # polygons falling, one to a cell of a grid
        cells = R.sample([(i, j) for i in range(8) for j in range(4)], R.randint(3, 12))
        for i, j in cells:
            lines.append("BLOCK " + polygon(0.8 + 1.3 * i + R.uniform(-0.03, 0.03), 0.7 + 1.3 * j, R.uniform(0.2, 0.6), R.randint(3, 7), R.uniform(0, 6.3)))
    elif kind == 2:  # a block split into pieces
        lines.append("BLOCK 1,0 1,3 7,3 7,0")
        for _ in range(R.randint(1, 5)):
            lines.append(f"SPLIT {R.uniform(0, 8):.2f} {R.uniform(-1, 0):.2f} {R.uniform(0, 8):.2f} {R.uniform(3, 4):.2f}")
        for _ in range(R.randint(0, 3)):
            lines.append(f"SPLIT -1 {R.uniform(0.3, 2.7):.2f} 9 {R.uniform(0.3, 2.7):.2f}")
    else:  # a column of boxes, aligned or offset, some tilted
        for j in range(R.randint(2, 7)):
            a = R.choice([0, 0, R.uniform(-0.3, 0.3)])
            cx, cy = 3 + R.choice([0, 0, R.uniform(-0.2, 0.2)]), 0.5 + j * 1.02
            lines.append("BLOCK " + polygon(cx, cy, 0.7, 4, math.pi / 4 + a))
    lines.append("FIX -2 13 -1 0")
    lines.append(f"GRAVITY {R.choice(['0', '0.5', '-1'])} -10")
    if R.random() < 0.4:
        lines.append(f"DAMP {R.uniform(0.01, 0.5):.2f} {R.uniform(1, 20):.1f}" + R.choice(["", " MASS", " STIFF"]))
    lines.append("SET OVERLAP ACCEPT")
    lines.append(f"CYCLE {R.randint(300, 1500)}")
    lines.append("STOP")
    return "\n".join(lines) + "\n"


def capped(text, cap=1500):
    out = []
    for line in text.splitlines():
        words = line.split()
        if len(words) == 2 and words[0].upper() in ("CYCLE", "CYC") and words[1].isdigit() and int(words[1]) > cap:
            line = f"{words[0]} {cap}"
        out.append(line)
    return "\n".join(out) + "\n"


def run(binary, deck, tag, out, backend):
    name = os.path.splitext(os.path.basename(deck))[0]
    state = os.path.join(out, f"{name}.{tag}.json")
    if os.path.exists(state):
        os.remove(state)
    with open(os.path.join(out, f"{name}.{tag}.log"), "w") as log:
        rc = subprocess.call([binary, "run", deck, "--backend", backend, "--out", os.path.join(out, f"o_{tag}_{name}"), "--state-json", state], stdout=log, stderr=subprocess.STDOUT, timeout=600)
    try:
        with open(state) as f:
            s = json.load(f)
        s.pop("provenance", None)
    except (OSError, ValueError):
        s = None
    return rc, s


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("base")
    p.add_argument("new")
    p.add_argument("--scenes", type=int, default=160, help="generated scenes besides examples/*.dat")
    p.add_argument("--backend", default="cpu")
    p.add_argument("--out", default="bitwise-out")
    a = p.parse_args()
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    decks_dir = os.path.join(a.out, "decks")
    os.makedirs(decks_dir, exist_ok=True)
    decks = []
    for ex in sorted(glob.glob(os.path.join(root, "examples", "*.dat"))):
        with open(ex) as f:
            text = f.read()
        if "d3" in os.path.basename(ex):
            continue  # 2D decks only
        path = os.path.join(decks_dir, "x_" + os.path.basename(ex))
        with open(path, "w") as f:
            f.write(capped(text))
        decks.append(path)
    for s in range(a.scenes):
        path = os.path.join(decks_dir, f"r{s:03d}.dat")
        with open(path, "w") as f:
            f.write(generated(s))
        decks.append(path)
    base, new = os.path.abspath(a.base), os.path.abspath(a.new)
    differ, ran_through = [], 0
    with ThreadPoolExecutor(max_workers=2) as pool:
        for deck in decks:
            b, n = pool.submit(run, base, deck, "base", a.out, a.backend), pool.submit(run, new, deck, "new", a.out, a.backend)
            (rb, sb), (rn, sn) = b.result(), n.result()
            ran_through += rb == 0
            if rb != rn or sb != sn:
                differ.append(deck)
                print(f"DIFF {os.path.basename(deck)}: exit {rb} / {rn}, state {'equal' if sb == sn else 'differs'}")
    print(f"{len(decks)} decks ({ran_through} ran to their end with the base), {len(differ)} differ")
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()
