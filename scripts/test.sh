#!/usr/bin/env bash
# README command 2: set up (packages + Release build) and run the whole test suite with ctest.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# --tools: the tests run the real programs that read our output (tests/tools, docs/tools.md)
"$root/scripts/setup.sh" --tools
build="${SWARMSIM_BUILD_DIR:-$root/build}"
cd "$build"
rc=0
ctest --output-on-failure -j "$(nproc)" "$@" || rc=$?
# ctest shows no output of a skipped test (exit 77): print each one's reason, so a log says why
awk '/^[0-9]+\/[0-9]+ Testing: /{name=$0; sub(/^[0-9]+\/[0-9]+ Testing: /, "", name)}
     /^SKIP/{skip=1; print "skipped: " name}
     /^<end of output>/{skip=0}
     skip{print "  " $0}' Testing/Temporary/LastTest.log 2>/dev/null || true
exit "$rc"
