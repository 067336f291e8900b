#!/usr/bin/env bash
# Prepares, on this machine, what a lent GPU machine needs to benchmark blockdem (the workplace's
# `device` tool; docs/BENCHMARKS.md): the release binary, stripped, in .devbin/, and the Vulkan and
# EGL loaders as Debian packages in .gl/ (that machine has the NVIDIA driver but no loader, and no
# network). Both folders are ignored by git and travel as the `run` call's `carry`:
#
#   bash scripts/device-prep.sh
#   device run, carry [".gl", ".devbin"]:  bash scripts/device-check.sh
#
# device-check.sh runs the whole bench (device-bench.sh), `blockdem compare` of the samples and
# the reference walls, and `blockdem verify --quick` (about 3 minutes on an H100), packing what
# they write into $OUT/results.tar.gz; device-bench.sh alone runs the bench; device-ab.sh measures
# two builds alternated (copy the older one into .devbin/ first).
set -euo pipefail
cd "$(dirname "$0")/.."
exclude="$(git rev-parse --git-path info/exclude)"
mkdir -p "$(dirname "$exclude")"
for d in /.gl/ /.devbin/; do
    grep -qxF "$d" "$exclude" 2>/dev/null || echo "$d" >> "$exclude"
done
cargo build --release --locked
mkdir -p .devbin
strip -o .devbin/blockdem target/release/blockdem
if ! ls .gl/*.deb > /dev/null 2>&1; then
    mkdir -p .gl /tmp/amd64/partial
    o=(-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64)
    apt-get "${o[@]}" update -qq
    (cd .gl && apt-get "${o[@]}" download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
fi
du -sh .devbin .gl
