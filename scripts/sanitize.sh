#!/usr/bin/env bash
# The test suite under AddressSanitizer + UndefinedBehaviorSanitizer (docs/testing.md).
#
#   scripts/sanitize.sh [CTEST_ARGS...]           install what is missing, build, run ctest
#   scripts/sanitize.sh --quick [CTEST_ARGS...]   the same without the long-running test cases (CI)
#   scripts/sanitize.sh --build-only              install what is missing and build (scripts/fuzz.sh uses this)
#
# Installs the missing Debian packages (the build dependencies of scripts/setup.sh,
# clang, its OpenMP, sanitizer and libFuzzer runtimes), then configures a clang
# build with -DSWARMSIM_FUZZ=ON (ASan + UBSan for the library, the CLI and the
# tests, plus the fuzz targets) so that this script and scripts/fuzz.sh share one
# build directory, and runs the whole suite with ctest. Any sanitizer report
# fails the test that caused it.
#
# Environment:
#   SWARMSIM_SANITIZE_BUILD_DIR  build directory (default: <repo>/build-fuzz, as scripts/fuzz.sh)
#   SWARMSIM_JOBS                parallel build jobs and ctest -j (default: nproc)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${SWARMSIM_SANITIZE_BUILD_DIR:-$root/build-fuzz}"
jobs="${SWARMSIM_JOBS:-$(nproc)}"

build_only=0
quick=0
case "${1:-}" in
  --build-only) build_only=1; shift ;;
  --quick) quick=1; shift ;;
esac

# --quick leaves out the test cases that simulate thousands of agents or whole
# scenarios for many steps: under the sanitizers they take 1-14 minutes each
# (together more than three quarters of the sanitized suite's time; docs/testing.md).
# The normal suite (scripts/test.sh) runs them; the sanitized run keeps every
# other case, the short runs of every model and the CLI tests included.
quick_exclude='BSwarm scenarios keep every insect|Field scenarios: no agent ends inside|CLI runs every shipped scenario'
quick_exclude+='|bit-identical for 1 and 2 threads|a moving goal re-solves|F_int approximation|invariants of a 1000-agent swarm'
quick_exclude+='|D2: a full disk is exit 3|Resume after|Resume with other thread counts|Resume of compressed'
quick_exclude+='|D9: two runs never write|shape: the moon forms|shape: the morph ends|shape: the horse follows|shape: 1 and 2 threads'
# second-order fast marching's error and convergence at up to 128^3 (about 2 minutes each sanitized); the
# second-order code runs sanitized in the smaller fast-marching and field-model cases
quick_exclude+='|Fast marching, second order: errors from a point|Fast marching, second order: converges'
# the real programs that read our output (ParaView, Blender, ffmpeg): they ran unsanitized above, and the
# export code they read is covered by the export tests here
quick_exclude+='|tools: |rows formatted in parallel blocks'
# process control and whole-command cases that run a scenario several times (30-60 s each sanitized): the
# signals, resume refusals, fit and evaluate code paths run sanitized in their shorter cases
quick_exclude+='|Resume refuses another scenario|SIGUSR1 writes a checkpoint|SIGTERM is answered within a second'
quick_exclude+='|fit: the command fits a value back|evaluate: HDF5 output against itself'

temporary_exclude=''

# --- packages (only the missing ones, as scripts/setup.sh) ---------------------
install_missing() {
  local missing=() p
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "sanitize: installing ${missing[*]}" >&2
  local sudo_cmd=()
  if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
}
# the build dependencies of scripts/setup.sh (without the Python tools), and clang
install_missing build-essential cmake pkg-config libcli11-dev nlohmann-json3-dev libhdf5-dev \
                libeigen3-dev libtinyobjloader-dev catch2 libnanoflann-dev libssl-dev libpagmo-dev clang
# clang's runtimes of the same version: sanitizers and libFuzzer (libclang-rt), OpenMP
clang_major="$(clang --version | sed -n 's/.*clang version \([0-9]*\)\..*/\1/p' | head -n1)"
if [ -z "$clang_major" ]; then
  echo "sanitize: cannot tell the clang version from 'clang --version'" >&2
  exit 2
fi
# (llvm-N: llvm-symbolizer, for stack traces with function names and lines)
install_missing "libclang-rt-$clang_major-dev" "libomp-$clang_major-dev" "libfuzzer-$clang_major-dev" "llvm-$clang_major"

# --- configure and build ---------------------------------------------------------
if [ ! -f "$build/CMakeCache.txt" ]; then
  CC=clang CXX=clang++ cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release -DSWARMSIM_FUZZ=ON >&2
elif ! grep -q '^SWARMSIM_FUZZ:BOOL=ON' "$build/CMakeCache.txt"; then
  cmake -S "$root" -B "$build" -DSWARMSIM_FUZZ=ON >&2
fi
if ! grep -q '^CMAKE_CXX_COMPILER:[A-Z]*=.*clang++' "$build/CMakeCache.txt"; then
  echo "sanitize: $build is not a clang build; remove it or set SWARMSIM_SANITIZE_BUILD_DIR" >&2
  exit 2
fi
cmake --build "$build" -j "$jobs" >&2
[ "$build_only" -eq 1 ] && exit 0

# --- run the suite ---------------------------------------------------------------
# Abort on the first report of either sanitizer, with a stack trace; leaks are
# reported at exit (LeakSanitizer, part of ASan). Settings given in the
# environment come last and win.
export ASAN_OPTIONS="detect_leaks=1:check_initialization_order=1:strict_init_order=1:abort_on_error=0${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
# third-party leaks our code cannot avoid (each entry says why)
export LSAN_OPTIONS="suppressions=$root/cmake/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
cd "$build"
exclude="$temporary_exclude"
[ -n "$exclude" ] && echo "sanitize: TEMPORARY: without the test cases matching: $exclude (known finding, see the script)" >&2
if [ "$quick" -eq 1 ]; then
  echo "sanitize: --quick: without the test cases matching: $quick_exclude" >&2
  exclude="${exclude:+$exclude|}$quick_exclude"
fi
ctest_args=(--output-on-failure -j "$jobs")
[ -n "$exclude" ] && ctest_args+=(-E "$exclude")
exec ctest "${ctest_args[@]}" "$@"
