#!/usr/bin/env bash
# Runs the whole test suite on a fresh Debian machine: installs what is missing, then
# `cargo test --release`. Used by CI (.ci/run) and by developers alike.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
# Mesa's software adapters run a dispatch's workgroups on a pool of worker threads, one per core.
# The test harness already runs a test per core, and the tests' scenes are small (a few
# workgroups a dispatch, thousands of dispatches): the pool's hand-offs cost more than they
# share, so the workgroups run one after another on the submitting thread instead (0 workers),
# ~1/3 less time for the suite on two cores. That the kernels' results do not depend on it is
# itself a test (gpu_cli::gpu_runs_do_not_depend_on_the_adapters_worker_threads, threads on).
export LP_NUM_THREADS="${LP_NUM_THREADS:-0}"
cargo test --release --locked "$@"
