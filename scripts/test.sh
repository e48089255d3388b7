#!/usr/bin/env bash
# Sets up (if needed), builds, and runs the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
# the HTML report's test opens the page in a real headless browser
source scripts/packages.sh
vln_install_missing test chromium strace
scripts/setup.sh
build_dir=${VLN_BUILD_DIR:-build}
cd "$build_dir"
started=$SECONDS
ctest --output-on-failure -j "${VLN_JOBS:-$(nproc)}" "$@"
echo "test: ctest took $((SECONDS - started)) s"
