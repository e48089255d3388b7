#!/usr/bin/env bash
# Installs every Debian package vlnce-cpp needs (only those missing), then
# configures and builds Release into build/. Idempotent: a second run only
# rebuilds what changed.
#
#   scripts/setup.sh            # packages + build
#   VLN_BUILD_DIR=build-asan VLN_CMAKE_ARGS="-DVLN_SANITIZE=ON" scripts/setup.sh
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  build-essential cmake ninja-build ccache pkg-config git
  libtorch-dev libopenblas0-openmp python3-torch
  libembree-dev libassimp-dev libosmesa6-dev libopencv-dev
  libyaml-cpp-dev libspdlog-dev libfmt-dev libeigen3-dev librecast-dev
  liblmdb-dev nlohmann-json3-dev libcli11-dev zlib1g-dev libgloo-dev
  googletest libgtest-dev libgmock-dev libbenchmark-dev
)

source scripts/packages.sh
vln_install_missing setup "${packages[@]}"
# the phases' times tell where CI's minutes go (.ci/run prints the total)
echo "setup: packages ready after ${SECONDS} s"

# Debian's LibTorch links the reference BLAS unless OpenBLAS is the selected
# alternative (matrix multiply ~25x slower otherwise): insist on it.
blas=$(readlink -f /usr/lib/x86_64-linux-gnu/libblas.so.3 2>/dev/null || true)
if [[ "$blas" != *openblas* ]]; then
  echo "setup: warning: libblas.so.3 resolves to '$blas', not OpenBLAS; LibTorch will be slow" >&2
fi

build_dir=${VLN_BUILD_DIR:-build}
export CCACHE_SLOPPINESS=pch_defines,time_macros,include_file_mtime,include_file_ctime
export CCACHE_MAXSIZE=${CCACHE_MAXSIZE:-5G}
jobs=${VLN_JOBS:-$(nproc)}
if [[ ! -f "$build_dir/CMakeCache.txt" ]]; then
  cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release ${VLN_CMAKE_ARGS:-}
fi
# VLN_BUILD_TARGETS (space-separated) builds only those targets, e.g. the
# binaries scripts/run.sh needs; the rest builds when scripts/test.sh runs
# shellcheck disable=SC2086
cmake --build "$build_dir" -j "$jobs" ${VLN_BUILD_TARGETS:+--target $VLN_BUILD_TARGETS}
echo "setup: built into $build_dir/ (binaries in $build_dir/bin) after ${SECONDS} s"
