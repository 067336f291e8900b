#!/usr/bin/env bash
# Runs on a lent GPU machine (see scripts/device-prep.sh): unpacks the loaders carried in .gl/,
# points them at the NVIDIA driver, lists the adapters and runs the whole benchmark on every
# backend, adapter and precision found (walls up to 10^6 blocks on a hardware GPU), writing the
# table and files to $OUT/bench and the log to $OUT/bench.log. Arguments replace the default
# `--backend all --rounds 3` of `blockdem bench` (e.g. --scene scaling --rounds 1, a short run).
set -uo pipefail
cd "$(dirname "$0")/.."
out="${OUT:-out}/bench"
mkdir -p "$out"
# The loaders only where the machine has none (unpacking over a system's own could break it).
if ! ldconfig -p | grep -q 'libvulkan.so.1 '; then
    for f in .gl/*.deb; do dpkg -x "$f" /; done
    ldconfig
fi
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
egl=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
[ -f "$icd" ] && export VK_DRIVER_FILES="$icd"
[ -f "$egl" ] && export __EGL_VENDOR_LIBRARY_FILENAMES="$egl"
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader || true
.devbin/blockdem adapters
args=("$@")
[ ${#args[@]} -eq 0 ] && args=(--backend all --rounds 3)
.devbin/blockdem bench "${args[@]}" --out "$out" 2>&1 | tee "${OUT:-out}/bench.log"
