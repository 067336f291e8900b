#!/usr/bin/env bash
# Runs on a lent GPU machine after scripts/device-prep.sh (carry [".gl", ".devbin"]): the bench
# a few scenes at a time (each `blockdem bench --scene S1,S2 --backend all --rounds 3` into its own
# folder, so that a step cut off by its time limit costs only itself), then the checks a hardware GPU adds
# to CI's software adapters: `blockdem compare` of the sample decks and the reference scenes
# against the f64 CPU in f32 and f64, and the quick verification suite on every backend found.
#
# The device tool gives a call ten minutes and a session fifteen, the machine's start included,
# so the whole script keeps to a deadline (DEADLINE seconds from its start, default 540): each
# step runs under the smaller of its own limit and the time left, the steps in the order of what
# the open issues most need measured (SCENES overrides the bench's list). Everything lands packed
# in $OUT/results.tar.gz, re-packed after every step so that a call killed at its limit still
# brings back what finished (the device tool brings back at most eight files); the logs also in
# $OUT.
set -uo pipefail
cd "$(dirname "$0")/.."
final="${OUT:-out}"
work=/tmp/blockdem-check
rm -rf "$work"
mkdir -p "$final" "$work"
began=$(date +%s)
deadline=$(( began + ${DEADLINE:-540} ))
pack() { tar -C "$work" -czf "$final/results.tar.gz" . ; cp "$work"/*.log "$final"/ 2>/dev/null; }
trap pack EXIT
# Seconds a step may take: its own limit, or what is left before the deadline.
allow() { local left=$(( deadline - $(date +%s) )); (( left < $1 )) && echo "$left" || echo "$1"; }
step() {
    local name="$1" limit="$2"
    shift 2
    local t
    t=$(allow "$limit")
    if (( t < 5 )); then
        echo "$name: skipped, the deadline has passed" | tee -a "$work/check.log"
        return
    fi
    local start
    start=$(date +%s)
    timeout "$t" "$@" > "$work/$name.txt" 2>&1
    echo "$name: rc $?, $(( $(date +%s) - start )) s (limit $t s)" | tee -a "$work/check.log"
    pack
}
source scripts/device-env.sh
{ nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader; .devbin/blockdem adapters; } \
    > "$work/adapters.log" 2>&1
# scenes:limit, in order of need: the scaling walls, rigid and SDEF in one run (the per-kernel
# profile at 10^6 blocks; the SDEF rows against the rigid ones), the zoned family, D3 on every
# backend, D3's wall of 10^5 and 10^6 bricks on the GPU alone (issue 31's H100 target: its
# contact-cycles/s, roofline and kernel times), the 10^5-brick wall through the cube's impact on
# the GPU (its detections' share and bytes, the ledger), then the reference scenes (each measured
# against the dry settle of the same run). An item scenes/backend/sizes:limit runs only that
# backend, at those sizes, one round.
for item in ${SCENES:-scaling,sdef-scaling:170 zones:80 d3-wall,d3-cubes:80 d3-wall/gpu/100000,1000000:120 d3-impact/gpu/100000:50 settle,impact,sdef,fluid:80}; do
    spec="${item%%:*}"
    scene="${spec%%/*}"
    name="bench-${scene//,/-}"
    args=(--backend all --rounds 3)
    if [[ "$spec" == */*/* ]]; then
        rest="${spec#*/}"
        args=(--backend "${rest%%/*}" --sizes "${rest#*/}" --rounds 1)
        name="$name-${rest#*/}"
        name="${name//,/-}"
    fi
    step "$name" "${item##*:}" .devbin/blockdem bench --scene "$scene" "${args[@]}" --out "$work/$name"
    grep -v "^bench \[" "$work/$name.txt" >> "$work/bench.log" 2>/dev/null
done
for deck in examples/udec1_point_load_cracking.dat examples/udec3_deformable_block.dat \
    examples/udec4_projectile_beam.dat examples/brick_wall_sdef.dat examples/brick_wall_impact.dat; do
    for p in f32 f64; do
        name="compare-$(basename "$deck" .dat)-$p"
        step "$name" 30 .devbin/blockdem compare "$deck" --adapter vulkan --precision "$p" --out "$work/compare/$name"
        tail -n 25 "$work/$name.txt" >> "$work/check.log" 2>/dev/null
    done
done
step verify-quick 200 .devbin/blockdem verify --quick --out "$work/verify"
cp "$work/verify-quick.txt" "$work/verify.log" 2>/dev/null
echo "total: $(( $(date +%s) - began )) s" | tee -a "$work/check.log"
