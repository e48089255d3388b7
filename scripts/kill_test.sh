#!/usr/bin/env bash
# kill -9 / --resume test of the trainer (tests/reliability/KillResumeTest):
# generates the tiny world (configs/world/tiny.yaml) with vlnce-data, trains
# a tiny DAgger run once without interruption and once SIGKILLed at random
# moments (timing, checkpoint writes, store commits) and resumed each time,
# and checks that the run completes, every checkpoint loads, the store is
# consistent, no collected episode was lost or duplicated, no temporary file
# is left and the final weights equal the uninterrupted run's bit for bit
# (trainer.exact_resume).
#
#   scripts/kill_test.sh [KILLS] [SEED]     # defaults: 10 kills, random seed
#
# Environment: VLN_BUILD_DIR (default build), VLN_JOBS (default 2).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
kills=${1:-10}
seed=${2:-$((RANDOM * 32768 + RANDOM))}
build=${VLN_BUILD_DIR:-build}
jobs=${VLN_JOBS:-2}

if [[ ! -f $build/CMakeCache.txt ]]; then
  VLN_BUILD_DIR=$build scripts/setup.sh
fi
cmake --build "$build" -j "$jobs" --target train vlnce-data KillResumeTest

# the world, generated once per build tree
world=$root/$build/tests/kill_test_world
if [[ ! -f $world/done ]]; then
  rm -rf "$world"
  echo "kill_test: generating the tiny world"
  "$build/bin/vlnce-data" generate --config configs/world/tiny.yaml \
    --out "$world/data" --scenes-dir "$world/scenes" --threads 2 >/dev/null
  touch "$world/done"
fi

echo "kill_test: $kills kills, seed $seed"
start=$(date +%s)
VLN_RELIABILITY_WORLD=$world VLN_KILL_COUNT=$kills VLN_KILL_SEED=$seed \
  "$build/tests/KillResumeTest" --gtest_color=no
echo "kill_test: passed in $(($(date +%s) - start)) s (seed $seed)"
