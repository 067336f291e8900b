#!/usr/bin/env bash
# Instructions a cycle of a deck on the CPU backend, one thread, counted by valgrind's cachegrind:
# the deck run with its CYCLE commands set to N cycles, less the same deck set to 1 cycle, over
# N - 1 (the set-up, parsing and the first detection cancel). Counts, unlike the wall clock, do not
# move with a shared machine's load: the way to compare two builds of the CPU cycle
# (docs/BENCHMARKS.md, "The rigid settle's cost").
#
#   scripts/instructions.sh BINARY DECK [N]      (N defaults to 600)
#   e.g. scripts/instructions.sh target/release/blockdem examples/brick_wall_settle.dat
#
# Needs valgrind (apt-get install valgrind). Prints "DECK: X.XXX M instructions a cycle".
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: $0 BINARY DECK [N]" >&2
  exit 2
fi
bin=$1
deck=$2
n=${3:-600}
command -v valgrind > /dev/null || { echo "$0: valgrind is not installed (apt-get install valgrind)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
count() {
  # The deck with every CYCLE (or CYC) command set to $1 cycles.
  sed -E "s/^(CYCLE|CYC|cycle|cyc)[[:space:]]+[0-9]+/\\1 $1/" "$deck" > "$work/deck_$1.dat"
  RAYON_NUM_THREADS=1 valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file="$work/cg_$1" \
    "$bin" run "$work/deck_$1.dat" --backend cpu --out "$work/out_$1" > /dev/null 2> "$work/err_$1" || {
    echo "$0: the run of $deck at $1 cycles failed:" >&2
    tail -5 "$work/err_$1" >&2
    exit 1
  }
  grep -E "I[[:space:]]+refs" "$work/err_$1" | tr -d ',' | awk '{print $NF}'
}
one=$(count 1)
many=$(count "$n")
awk -v a="$one" -v b="$many" -v n="$n" -v d="$deck" 'BEGIN { printf "%s: %.3f M instructions a cycle\n", d, (b - a) / (n - 1) / 1e6 }'
