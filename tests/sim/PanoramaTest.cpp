// Tests src/sim/Panorama.cpp: every view is the single-view observation at
// the rotated heading (bit for bit), the views go counter-clockwise from the
// agent's heading, parallel rendering changes nothing, and bad configs are
// refused with the field named.

#include "sim/Panorama.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "sim/Renderer.h"
#include "sim/SimTestScenes.h"
#include "sim/SimTestSuites.h"
#include "sim/Simulator.h"

namespace vln::sim {
namespace {

using ::testing::HasSubstr;

// A closed 6 m x 6 m room (walls at x, z = +-3) with a 1 m cube spanning
// x in [1.5, 2.5], z in [-0.5, 0.5] (SimTestScenes.h).
std::shared_ptr<const Scene> testScene() {
  return test::roomWithCube("panorama-room", /*ceiling=*/true);
}

// Small views of different sizes for RGB and depth, so that they take
// separate passes as the default 224/256 cameras do; odd depth sizes put
// the middle pixel on the optical axis. The depth camera sits 0.5 m up so
// that its axis meets the 1 m cube.
PanoramaConfig smallPanorama(int threads) {
  PanoramaConfig panorama;
  panorama.rgb = {28, 28, 90.0f, 1.25f};
  panorama.depth.camera = {33, 33, 90.0f, 0.5f};
  panorama.threads = threads;
  return panorama;
}

SimConfig backendConfig(RendererBackend backend) {
  SimConfig config;
  config.renderer = backend;
  return config;
}

class PanoramaTest : public test::SceneSuite<testScene>,
                     public ::testing::WithParamInterface<RendererBackend> {};

INSTANTIATE_TEST_SUITE_P(Backends, PanoramaTest,
                         ::testing::Values(RendererBackend::kEmbree,
                                           RendererBackend::kOsMesa,
                                           RendererBackend::kRaster),
                         [](const auto& info) {
                           return std::string(rendererBackendName(info.param));
                         });

TEST_P(PanoramaTest, EveryViewIsTheSingleViewObservationAtItsHeading) {
  const PanoramaConfig config = smallPanorama(/*threads=*/1);
  Simulator sim(scene_, backendConfig(GetParam()), TaskConfig{});
  const AgentState start{Vec3f(-0.7f, 0.0f, 0.9f), 0.4f};
  sim.reset(start);
  Panorama panorama;
  sim.observePanorama(config, panorama);
  ASSERT_EQ(panorama.num_views, 12);
  ASSERT_EQ(panorama.rgb.size(), 12u * 28u * 28u * 3u);
  ASSERT_EQ(panorama.depth.size(), 12u * 33u * 33u);
  EXPECT_EQ(panorama.heading, 0.4f);

  // a simulator whose own cameras are the panorama's, turned to each view
  SimConfig single = backendConfig(GetParam());
  single.rgb = config.rgb;
  single.depth = config.depth;
  Simulator turned(scene_, single, TaskConfig{});
  Observation obs;
  for (int view = 0; view < 12; ++view) {
    turned.reset({sim.episode().agent.position,
                  panoramaViewHeading(start.heading, view, 12)});
    turned.observe(obs);
    const std::vector<uint8_t> rgb(
        panorama.rgb.begin() + view * obs.rgb.size(),
        panorama.rgb.begin() + (view + 1) * obs.rgb.size());
    const std::vector<float> depth(
        panorama.depth.begin() + view * obs.depth.size(),
        panorama.depth.begin() + (view + 1) * obs.depth.size());
    // same renderer code, same poses: bit-identical, not merely close
    EXPECT_EQ(rgb, obs.rgb) << "view " << view;
    EXPECT_EQ(depth, obs.depth) << "view " << view;
  }
}

TEST_P(PanoramaTest, ViewsGoCounterClockwiseFromTheHeading) {
  Simulator sim(scene_, backendConfig(GetParam()), TaskConfig{});
  const PanoramaConfig config = smallPanorama(1);
  // at (-1, 0): the wall z = -3 is 3 m ahead (heading 0 looks along -Z),
  // the wall x = -3 2 m to the left, the cube's face x = 1.5 2.5 m to the
  // right, the wall z = 3 3 m behind
  sim.reset({Vec3f(-1.0f, 0.0f, 0.0f), 0.0f});
  Panorama panorama;
  sim.observePanorama(config, panorama);
  const size_t viewSize = 33u * 33u;
  const auto centre = [&](int view) {
    // normalised by max_depth 10
    return 10.0f * panorama.depth[view * viewSize + 16 * 33 + 16];
  };
  EXPECT_NEAR(centre(0), 3.0f, 0.02f);  // ahead
  EXPECT_NEAR(centre(3), 2.0f, 0.02f);  // 90 degrees counter-clockwise: left
  EXPECT_NEAR(centre(6), 3.0f, 0.02f);  // behind
  EXPECT_NEAR(centre(9), 2.5f, 0.02f);  // 270 degrees: right, the cube
  // view 1 (30 degrees left of -Z) meets the wall z = -3 at 3 / cos 30
  EXPECT_NEAR(centre(1), 3.0f / std::cos(kPi / 6.0f), 0.03f);

  // turning the agent left by one view shifts the panorama by one view
  sim.reset({Vec3f(-1.0f, 0.0f, 0.0f), 2.0f * kPi / 12.0f});
  Panorama turned;
  sim.observePanorama(config, turned);
  for (int view = 0; view < 11; ++view)
    EXPECT_NEAR(10.0f * turned.depth[view * viewSize + 16 * 33 + 16],
                centre(view + 1), 1e-4f)
        << "view " << view;
}

TEST_P(PanoramaTest, TwoThreadsRenderTheSameImagesAsOne) {
  // with several renderers the last views come as separate colour and
  // depth units; three renderers split three views so
  for (const int threads : {2, 3}) {
    SCOPED_TRACE(::testing::Message() << threads << " threads");
    Simulator one(scene_, backendConfig(GetParam()), TaskConfig{});
    Simulator many(scene_, backendConfig(GetParam()), TaskConfig{});
    Panorama a;
    Panorama b;
    for (const AgentState& state :
         {AgentState{Vec3f(-1.5f, 0.0f, 1.5f), 0.9f},
          AgentState{Vec3f(0.5f, 0.0f, -2.0f), -2.5f}}) {
      one.reset(state);
      many.reset(state);
      one.observePanorama(smallPanorama(1), a);
      // a fresh panorama first (unrendered views would stay empty), then
      // again: the second render reuses the buffers and the renderers
      b = Panorama{};
      many.observePanorama(smallPanorama(threads), b);
      EXPECT_EQ(a.rgb, b.rgb);
      EXPECT_EQ(a.depth, b.depth);
      many.observePanorama(smallPanorama(threads), b);
      EXPECT_EQ(a.rgb, b.rgb);
      EXPECT_EQ(a.depth, b.depth);
    }
  }
}

TEST(PanoramaViewHeadingTest, AddsEqualStepsAndWraps) {
  EXPECT_FLOAT_EQ(panoramaViewHeading(0.0f, 0, 12), 0.0f);
  EXPECT_FLOAT_EQ(panoramaViewHeading(0.0f, 3, 12), kPi / 2.0f);
  // 270 degrees wraps to -90
  EXPECT_FLOAT_EQ(panoramaViewHeading(0.0f, 9, 12), -kPi / 2.0f);
  EXPECT_NEAR(panoramaViewHeading(3.0f, 6, 12), 3.0f - kPi, 1e-6f);
  EXPECT_FLOAT_EQ(panoramaViewHeading(1.0f, 0, 1), 1.0f);
}

class PanoramaConfigTest : public test::SceneSuite<testScene> {};

TEST_F(PanoramaConfigTest, RejectsBadConfigsNamingTheField) {
  Simulator sim(scene_, SimConfig{}, TaskConfig{});
  sim.reset({Vec3f(-1.0f, 0.0f, 0.0f), 0.0f});
  const auto expectRejected = [&](const PanoramaConfig& panorama,
                                  const std::string& field) {
    Panorama out;
    try {
      sim.observePanorama(panorama, out);
      ADD_FAILURE() << "expected std::invalid_argument for " << field;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr(field));
    }
    EXPECT_THROW(PanoramaRenderer(*scene_, panorama, RendererBackend::kEmbree),
                 std::invalid_argument);
  };
  PanoramaConfig config;
  config.num_views = 0;
  expectRejected(config, "num_views");
  config = PanoramaConfig{};
  config.threads = 0;
  expectRejected(config, "threads");
  config = PanoramaConfig{};
  config.rgb.width = 0;
  expectRejected(config, "rgb.width");
  // 3 views of 90 degrees leave three 30 degree gaps
  config = PanoramaConfig{};
  config.num_views = 3;
  expectRejected(config, "leave gaps");
  config = PanoramaConfig{};
  config.depth.camera.hfov = 20.0f;
  expectRejected(config, "panorama.depth.hfov");
  config = PanoramaConfig{};
  config.depth.min_depth = 4.0f;
  config.depth.max_depth = 3.0f;
  expectRejected(config, "min_depth");
  // four 90 degree views just cover the circle
  config = PanoramaConfig{};
  config.num_views = 4;
  EXPECT_NO_THROW(PanoramaRenderer(*scene_, config, RendererBackend::kEmbree));
}

}  // namespace
}  // namespace vln::sim
