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
source scripts/device-env.sh
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader || true
.devbin/blockdem adapters
args=("$@")
[ ${#args[@]} -eq 0 ] && args=(--backend all --rounds 3)
.devbin/blockdem bench "${args[@]}" --out "$out" 2>&1 | tee "${OUT:-out}/bench.log"
