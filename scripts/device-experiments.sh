#!/usr/bin/env bash
# Runs on a lent GPU machine after scripts/device-prep.sh (carry [".gl", ".devbin"]): the
# measurements of docs/BENCHMARKS.md that need a hardware GPU beyond the bench itself, each a
# `blockdem bench --scene scaling --backend gpu` at 10^5 and 10^6 blocks, results packed into
# $OUT/experiments.tar.gz and the logs into $OUT/*.log:
#   - the cycle kernels' workgroup size (BLOCKDEM_WORKGROUP_SIZE 64, 128, 256, then 64 again to
#     see the machine's drift), results bit for bit the same;
#   - the adjacency's whole upload against its edit on the device (BLOCKDEM_ADJACENCY_EDIT=0).
set -uo pipefail
cd "$(dirname "$0")/.."
out="${OUT:-out}"
work=/tmp/blockdem-experiments
mkdir -p "$out" "$work"
source scripts/device-env.sh
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader || true
sizes="${SIZES:-100000,1000000}"
bench() {
    local name="$1"
    shift
    echo "=== $name: $*" | tee -a "$out/experiments.log"
    env "$@" .devbin/blockdem bench --scene scaling --backend gpu --adapter vulkan --sizes "$sizes" --rounds 3 --out "$work/$name" > "$work/$name.log" 2>&1
    sed -n '/^SCALING/,/^TARGETS/p' "$work/$name.log" | grep -E "^(vulkan|backend)" | tee -a "$out/experiments.log"
    grep -E "device (law_of_motion|contact_forces)|^  vulkan .* at [0-9]+ blocks \(" "$work/$name.log" | tee -a "$out/experiments.log"
}
for w in ${WORKGROUPS:-128 256 64}; do
    bench "wg$w" BLOCKDEM_WORKGROUP_SIZE="$w"
done
bench adjacency_upload BLOCKDEM_ADJACENCY_EDIT=0
bench adjacency_edit BLOCKDEM_ADJACENCY_EDIT=1
tar -czf "$out/experiments.tar.gz" -C "$work" .
