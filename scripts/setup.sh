#!/usr/bin/env bash
# Install the Debian 12 packages swarmsim needs (only the missing ones), then
# configure and build in Release. Idempotent: with everything present and the
# build up to date it only runs an incremental `cmake --build`.
#
#   scripts/setup.sh           the packages to build and run swarmsim (and its Python scripts)
#   scripts/setup.sh --tools   also the programs that read our output, for their tests and
#                              scripts (docs/tools.md): ParaView, Blender, ffmpeg, and Xvfb (an X server
#                              without a screen) for ParaView's renders, pandas for the Python examples,
#                              scikit-fmm to compare our fast marching with (scripts/fmm_compare.py)
set -euo pipefail
tools=0
if [ "${1:-}" = "--tools" ]; then tools=1; shift; fi
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${SWARMSIM_BUILD_DIR:-$root/build}"

packages=(build-essential cmake pkg-config libcli11-dev nlohmann-json3-dev libhdf5-dev
          hdf5-tools libeigen3-dev libtinyobjloader-dev catch2 libnanoflann-dev libssl-dev libpagmo-dev python3 python3-h5py time
          python3-matplotlib)
if [ "$tools" = 1 ]; then
  packages+=(paraview python3-paraview blender ffmpeg xvfb xauth python3-pandas python3-scikit-fmm)
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}" >&2
  sudo_cmd=()
  if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
fi

if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release >&2
fi
cmake --build "$build" -j "$(nproc)" >&2
