// Tests src/waypoint/WaypointCommands.cpp: the command end to end on the
// tiny generated world (configs/world/tiny.yaml), its report's invariants
// and determinism, option checks and a missing dataset named in the error
// (the metrics themselves are tested in WaypointMetricsTest, targets and
// baseline in their own tests).

#include "waypoint/WaypointCommands.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sstream>

#include <nlohmann/json.hpp>

#include "common/Config.h"
#include "common/FileIo.h"
#include "support/TestPaths.h"
#include "world/WorldConfig.h"
#include "world/WorldGenerator.h"

namespace vln::waypoint {
namespace {

using ::testing::HasSubstr;

void expectRejected(const WaypointMetricsOptions& options,
                    const std::string& expected) {
  std::ostringstream out;
  try {
    runWaypointMetricsCommand(options, out);
    ADD_FAILURE() << "expected an exception mentioning " << expected;
  } catch (const std::exception& e) {
    EXPECT_THAT(e.what(), HasSubstr(expected));
  }
}

// The tiny world with five houses, generated once for the file (in about a
// second).
class WaypointCommandsWorldTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    auto config = common::loadConfigFile<world::WorldConfig>(
        test::sourcePath() / "configs" / "world" / "tiny.yaml");
    // a few more houses than tiny's three, so that train has several for
    // the threads to share
    config.houses = 5;
    world::generateWorld(config,
                         {dir_->path() / "data", dir_->path() / "scenes", 2});
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static WaypointMetricsOptions options() {
    WaypointMetricsOptions options;
    options.dataset = dir_->path() / "data";
    options.scenes_dir = dir_->path() / "scenes";
    options.json = true;
    return options;
  }
  static nlohmann::json run(const WaypointMetricsOptions& options) {
    std::ostringstream out;
    EXPECT_EQ(runWaypointMetricsCommand(options, out), 0);
    return nlohmann::json::parse(out.str());
  }
  static inline test::TempDir* dir_ = nullptr;
};

TEST_F(WaypointCommandsWorldTest, ReportsConsistentMetricsOnTheSplitsHouses) {
  WaypointMetricsOptions opts = options();
  opts.out = dir_->path() / "report.json";
  const nlohmann::json report = run(opts);
  EXPECT_EQ(report["split"], "val_unseen");
  ASSERT_GE(report["houses"].size(), 1u);
  const int nodes = report["nodes"];
  const int kept = report["kept"];
  EXPECT_GT(kept, 0);
  EXPECT_LE(kept, report["scored"].get<int>());
  EXPECT_EQ(report["scored"], report["valid"]);  // no --max-nodes
  EXPECT_LE(report["valid"].get<int>(), nodes);
  // every kept node is scored by both rows; NMS keeps at most 5 candidates
  const nlohmann::json& baseline = report["baseline"];
  const nlohmann::json& targets = report["targets"];
  EXPECT_EQ(baseline["nodes"], kept);
  EXPECT_EQ(targets["nodes"], kept);
  EXPECT_LE(baseline["candidates"].get<int>(), 5 * kept);
  EXPECT_EQ(baseline["targets"], targets["targets"]);
  // the targets' own cells: as many as the targets, within half a cell of
  // them (1.5 degrees at 3.125 m is 0.08 m, half a distance bin 0.125 m)
  EXPECT_EQ(targets["delta"], 0.0);
  EXPECT_LT(targets["hausdorff"].get<double>(), 0.15);
  EXPECT_GE(baseline["open_share"].get<double>(), 0.0);
  EXPECT_LE(baseline["open_share"].get<double>(), 1.0);
  // --out holds the same report
  EXPECT_EQ(nlohmann::json::parse(common::readFile(opts.out)), report);
}

TEST_F(WaypointCommandsWorldTest, DeterministicAcrossThreadsAndCapsNodes) {
  WaypointMetricsOptions one = options();
  one.threads = 1;
  one.split = "train";
  one.max_nodes = 6;
  WaypointMetricsOptions two = one;
  two.threads = 2;
  const nlohmann::json report = run(one);
  EXPECT_GE(report["houses"].size(), 2u);
  EXPECT_EQ(run(two), report);
  // six nodes of each train house
  EXPECT_EQ(report["scored"], 6 * static_cast<int>(report["houses"].size()));
}

TEST(WaypointCommandsTest, RejectsBadOptionsNamingThem) {
  WaypointMetricsOptions options;
  options.max_nodes = -2;
  expectRejected(options, "--max-nodes");
  options = WaypointMetricsOptions{};
  options.threads = 0;
  expectRejected(options, "--threads");
  options = WaypointMetricsOptions{};
  options.panorama.num_views = 2;
  expectRejected(options, "leave gaps");
  options = WaypointMetricsOptions{};
  options.dataset = "/nonexistent/dataset";
  expectRejected(options, "/nonexistent/dataset/val_unseen/val_unseen.json.gz");
}

}  // namespace
}  // namespace vln::waypoint
