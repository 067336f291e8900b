#!/usr/bin/env bash
# Runs the whole test suite on a fresh Debian machine: installs what is missing, then
# `cargo test --release`. Used by CI (.ci/run) and by developers alike; arguments go to each
# `cargo test` (e.g. --no-fail-fast).
#
# The suite is built once, then run as two `cargo test` processes side by side: tests/verify.rs
# (the closed-form suite on every backend, the longest binary by far) beside all the other
# targets, one after another as cargo runs them. On CI's two cores the software adapters'
# runs leave a core idle much of the time; side by side the two halves take about the longer
# one's time. The verify half's output is printed after the rest's, whole; either half failing
# fails the script.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
cargo test --release --locked --no-run "$@"
others=(--lib)
for t in tests/*.rs; do
  name="$(basename "$t" .rs)"
  [ "$name" = verify ] || others+=(--test "$name")
done
verify_log="$(mktemp)"
trap 'rm -f "$verify_log"' EXIT
cargo test --release --locked --test verify "$@" >"$verify_log" 2>&1 &
verify_pid=$!
status=0
cargo test --release --locked "${others[@]}" "$@" || status=$?
# The doc tests (cargo runs them alone: --doc takes no other target).
cargo test --release --locked --doc "$@" || status=$?
verify_status=0
wait "$verify_pid" || verify_status=$?
echo "---- tests/verify.rs (ran beside the others) ----"
cat "$verify_log"
if [ "$status" -ne 0 ] || [ "$verify_status" -ne 0 ]; then
  echo "blockdem: tests failed (others: exit $status, verify: exit $verify_status)" >&2
  exit 1
fi
