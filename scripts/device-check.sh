#!/usr/bin/env bash
# Runs on a lent GPU machine after scripts/device-prep.sh (carry [".gl", ".devbin"]): the whole
# bench (scripts/device-bench.sh), then the checks a hardware GPU adds to CI's software adapters:
# `blockdem compare` of the sample decks and the reference scenes against the f64 CPU in f32 and
# f64, and the quick verification suite on every backend found. Everything lands packed in
# $OUT/results.tar.gz (the device tool brings back at most eight files), the logs also in $OUT.
# Each step has its own time limit (STEP_LIMIT seconds, default 60) so that one slow step cannot
# cost the others their turn.
set -uo pipefail
cd "$(dirname "$0")/.."
final="${OUT:-out}"
work=/tmp/blockdem-check
mkdir -p "$final" "$work"
limit="${STEP_LIMIT:-60}"
pack() { tar -C "$work" -czf "$final/results.tar.gz" . ; cp "$work"/*.log "$final"/ 2>/dev/null; }
trap pack EXIT
OUT="$work" timeout "${BENCH_LIMIT:-240}" bash scripts/device-bench.sh "$@" > /dev/null 2>&1
echo "bench: rc $?" | tee -a "$work/check.log"
source scripts/device-env.sh
for deck in examples/udec1_point_load_cracking.dat examples/udec3_deformable_block.dat \
    examples/udec4_projectile_beam.dat examples/brick_wall_sdef.dat examples/brick_wall_impact.dat; do
    for p in f32 f64; do
        name="$(basename "$deck" .dat)-$p"
        start=$(date +%s)
        timeout "$limit" .devbin/blockdem compare "$deck" --adapter vulkan --precision "$p" \
            --out "$work/compare/$name" > "$work/compare-$name.txt" 2>&1
        rc=$?
        echo "$name: rc $rc, $(( $(date +%s) - start )) s" | tee -a "$work/check.log"
        tail -n 25 "$work/compare-$name.txt" >> "$work/check.log"
    done
done
start=$(date +%s)
timeout "${VERIFY_LIMIT:-150}" .devbin/blockdem verify --quick --out "$work/verify" > "$work/verify.log" 2>&1
echo "verify --quick: rc $?, $(( $(date +%s) - start )) s" | tee -a "$work/check.log"
