#!/usr/bin/env bash
# README command 2: set up (packages + Release build) and run the whole test suite with ctest.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# --tools: the tests run the real programs that read our output (tests/tools, docs/tools.md)
"$root/scripts/setup.sh" --tools
build="${SWARMSIM_BUILD_DIR:-$root/build}"
cd "$build"
exec ctest --output-on-failure -j "$(nproc)" "$@"
