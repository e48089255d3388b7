#pragma once
// The fixture of the end-to-end tests that run a binary of the build tree
// (train, eval) on the tiny world: TrainEndToEndTest, DistributedTrainingTest
// and EvalBinaryTest.

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <utility>

#include "support/TestPaths.h"
#include "support/TestUtil.h"
#include "train/TrainTestWorld.h"

namespace vln::train::test {

/// Tests of bin/<binary> on tinyWorld() (world_) in a fresh directory
/// (dir_); skipped while that binary is not built. A SetUp() of its own
/// calls this one first and returns when IsSkipped().
class TinyWorldBinaryTest : public ::testing::Test {
 protected:
  explicit TinyWorldBinaryTest(std::string binary)
      : binary_(std::move(binary)) {}

  void SetUp() override {
    if (!std::filesystem::exists(vln::test::binary(binary_)))
      GTEST_SKIP() << "build the " << binary_ << " binary first";
    world_ = &tinyWorld();
  }

  const TinyWorld* world_ = nullptr;
  vln::test::TempDir dir_;

 private:
  std::string binary_;
};

}  // namespace vln::train::test
