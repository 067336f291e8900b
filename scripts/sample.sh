#!/usr/bin/env bash
# Runs the main job on a fresh Debian machine: UDEC sample problem 1 (point-load cracking) on the
# best backend found, falling back to the CPU. Plots and the final state land in out/sample1/.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
mkdir -p out/sample1
cargo run --release --locked -- run examples/udec1_point_load_cracking.dat --backend auto \
  --out out/sample1 --state-json out/sample1/state.json "$@"
