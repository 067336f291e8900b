#!/usr/bin/env bash
# Runs on a lent GPU machine (see scripts/device-prep.sh): two builds of blockdem measured back to
# back, alternated (A B A B …), on the same scaling walls, so that their ratio is taken on the same
# machine minutes apart (docs/BENCHMARKS.md: "ratio measured in one run"). Usage:
#   bash scripts/device-ab.sh .devbin/blockdem-OLD .devbin/blockdem [REPEATS] [bench arguments]
# Default bench arguments: --scene scaling --backend gpu --adapter vulkan --sizes 100000,1000000
# --rounds 3. Each run's SCALING rows and kernel times go to $OUT/ab.log, its files to
# $OUT/ab.tar.gz.
set -uo pipefail
cd "$(dirname "$0")/.."
a="$1"
b="$2"
repeats="${3:-2}"
shift 3 2>/dev/null || shift $#
args=("$@")
[ ${#args[@]} -eq 0 ] && args=(--scene scaling --backend gpu --adapter vulkan --sizes 100000,1000000 --rounds 3)
out="${OUT:-out}"
work=/tmp/blockdem-ab
mkdir -p "$out" "$work"
source scripts/device-env.sh
for i in $(seq 1 "$repeats"); do
    for bin in "$a" "$b"; do
        name="$(basename "$bin")-$i"
        echo "=== $name: ${args[*]}" | tee -a "$out/ab.log"
        "$bin" bench "${args[@]}" --out "$work/$name" > "$work/$name.log" 2>&1
        sed -n '/^SCALING/,/^TIME PER STAGE/p' "$work/$name.log" | grep -E "^(vulkan|gl|cpu) " | tee -a "$out/ab.log"
        grep -E "^    device |^  (vulkan|gl).* blocks \(" "$work/$name.log" | tee -a "$out/ab.log"
    done
done
tar -C "$work" -czf "$out/ab.tar.gz" .
