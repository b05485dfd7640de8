#!/usr/bin/env bash
# README command 1: set up (packages + Release build) and run the default scenario.
# Extra arguments are passed to `swarmsim run`.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/setup.sh"
build="${SWARMSIM_BUILD_DIR:-$root/build}"
mkdir -p "$root/out"
exec "$build/swarmsim" run "$root/scenarios/default.json" -o "$root/out/default.h5" --force "$@"
