#!/usr/bin/env bash
# Style gates CI runs before the tests: rustfmt (rustfmt.toml), clippy on every target with
# warnings as errors, and the API docs with warnings as errors (broken intra-doc links).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo fmt --check
cargo clippy --release --all-targets --locked -- -D warnings
RUSTDOCFLAGS="-D warnings" cargo doc --release --no-deps --locked
