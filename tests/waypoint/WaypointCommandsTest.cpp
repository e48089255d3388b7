// Tests src/waypoint/WaypointCommands.cpp: option checks and a missing
// dataset named in the error (the metrics themselves are tested in
// WaypointMetricsTest, targets and baseline in their own tests).

#include "waypoint/WaypointCommands.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sstream>

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
