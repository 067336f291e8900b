#!/usr/bin/env bash
# Runs the whole test suite on a fresh Debian machine: installs what is missing, then
# `cargo test --release`. Used by CI (.ci/run) and by developers alike.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
cargo test --release --locked "$@"
