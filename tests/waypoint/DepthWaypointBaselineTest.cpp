// Tests src/waypoint/DepthWaypointBaseline.cpp: free distances read from a
// rendered depth panorama of a room of known size, the candidates' spacing,
// order and distances, and the config checks.

#include "waypoint/DepthWaypointBaseline.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "sim/Panorama.h"
#include "sim/Scene.h"
#include "sim/SimTestScenes.h"
#include "sim/SimTestSuites.h"

namespace vln::waypoint {
namespace {

using ::testing::HasSubstr;

// A closed 6 m x 6 m room (walls at x, z = +-3, ceiling 2.7 m) with a 1 m
// cube spanning x in [1.5, 2.5], z in [-0.5, 0.5].
std::shared_ptr<const sim::Scene> room() {
  return test::roomWithCube("baseline-room", /*ceiling=*/true);
}

class DepthWaypointBaselineTest : public test::SceneSuite<room> {
 protected:
  // 12 depth views of 128x128 (small, for speed), raw metres
  static sim::PanoramaConfig config() {
    sim::PanoramaConfig panorama;
    panorama.rgb = {16, 16, 90.0f, 1.25f};
    panorama.depth.camera = {128, 128, 90.0f, 1.25f};
    return panorama;
  }
  static sim::Panorama render(const sim::PanoramaConfig& panorama, float x,
                              float z, float heading) {
    sim::PanoramaRenderer renderer(*scene_, panorama,
                                   sim::RendererBackend::kEmbree);
    sim::Panorama pano;
    renderer.render({*scene_->navmesh().snapPoint({x, 0.0f, z}), heading},
                    pano);
    return pano;
  }
};

TEST_F(DepthWaypointBaselineTest, FreeDistancesAreTheRoomsWalls) {
  const sim::PanoramaConfig panorama = config();
  const DepthBaselineResult result = depthBaselineCandidates(
      render(panorama, -1.0f, 0.0f, 0.0f), panorama, DepthBaselineConfig{});
  // from (-1, 0) facing -Z: wall 3 m ahead, 2 m left (-X), the cube 2.5 m
  // right, 3 m behind; 45 degrees left-ahead the -X wall at 2 / cos 45,
  // less half_width * tan 45 where the corridor's edge meets it first
  EXPECT_NEAR(result.free[0], 3.0f, 0.05f);
  EXPECT_NEAR(result.free[30], 2.0f, 0.05f);
  EXPECT_NEAR(result.free[90], 2.5f, 0.05f);
  EXPECT_NEAR(result.free[60], 3.0f, 0.05f);
  EXPECT_NEAR(result.free[15], 2.0f / std::cos(kPi / 4.0f) - 0.2f, 0.05f);

  // candidates: by decreasing free distance, more than 7 bins apart, at
  // most 5, clearance 0.5 m short of the obstacle and within 3 m
  ASSERT_FALSE(result.candidates.empty());
  ASSERT_LE(result.candidates.size(), 5u);
  for (size_t i = 0; i < result.candidates.size(); ++i) {
    const Candidate& c = result.candidates[i];
    EXPECT_FLOAT_EQ(c.score, result.free[static_cast<size_t>(c.heading_bin)]);
    EXPECT_NEAR(c.distance, std::min(c.score - 0.5f, 3.0f), 0.125f + 1e-5f);
    if (i > 0) {
      EXPECT_LE(c.score, result.candidates[i - 1].score);
    }
    for (size_t j = 0; j < i; ++j) {
      const int gap =
          std::abs(c.heading_bin - result.candidates[j].heading_bin);
      EXPECT_GT(std::min(gap, kNumHeadings - gap), 7);
    }
  }
  // the farthest view is towards the far corner (+X, -Z), around the cube:
  // the first pick lies right of ahead (bins 60..119 are the right half)
  EXPECT_GT(result.candidates[0].heading_bin, 90);
  EXPECT_GT(result.candidates[0].score, 3.5f);
}

TEST_F(DepthWaypointBaselineTest, TurningTheAgentRotatesTheFreeDistances) {
  const sim::PanoramaConfig panorama = config();
  const auto ahead = depthBaselineCandidates(
      render(panorama, -1.0f, 0.0f, 0.0f), panorama, DepthBaselineConfig{});
  // turned left by 30 degrees = 10 bins: relative bin h then is bin h + 10
  const auto turned =
      depthBaselineCandidates(render(panorama, -1.0f, 0.0f, kPi / 6.0f),
                              panorama, DepthBaselineConfig{});
  for (int h = 0; h < kNumHeadings; h += 7)
    EXPECT_NEAR(turned.free[static_cast<size_t>(h)],
                ahead.free[static_cast<size_t>((h + 10) % kNumHeadings)], 0.05f)
        << "bin " << h;
}

TEST_F(DepthWaypointBaselineTest, RequiresMoreFreeSpaceThanMinFree) {
  const sim::PanoramaConfig panorama = config();
  DepthBaselineConfig strict;
  strict.min_free = 20.0f;  // more than the room allows
  EXPECT_TRUE(depthBaselineCandidates(render(panorama, 0.0f, 1.5f, 0.0f),
                                      panorama, strict)
                  .candidates.empty());
}

TEST_F(DepthWaypointBaselineTest, RejectsMismatchedPanoramasAndBadConfigs) {
  const sim::PanoramaConfig panorama = config();
  const sim::Panorama pano = render(panorama, -1.0f, 0.0f, 0.0f);
  sim::PanoramaConfig other = panorama;
  other.depth.camera.width = 64;
  try {
    depthBaselineCandidates(pano, other, DepthBaselineConfig{});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("does not match the panorama config"));
  }
  DepthBaselineConfig bad;
  bad.max_candidates = 0;
  try {
    depthBaselineCandidates(pano, panorama, bad);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("max_candidates"));
  }
}

}  // namespace
}  // namespace vln::waypoint
