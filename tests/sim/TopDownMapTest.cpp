// Tests src/sim/TopDownMap.cpp: canvas extent, the colours of navigable
// space, obstacles and objects, the markers drawn on top, floor selection
// and the PNG file.

#include "sim/TopDownMap.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/FileIo.h"
#include "sim/Scene.h"
#include "sim/SimTestScenes.h"
#include "sim/SimTestSuites.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::sim {
namespace {

using test::addQuad;
using test::addWalls;
using ::testing::HasSubstr;

// A 6 m x 6 m walled room at y = 0 with a red 1 m cube (object 4, "table")
// centred at (2, 0.5, 0).
std::shared_ptr<const Scene> roomScene() {
  return test::roomWithCube("map-room", /*ceiling=*/false);
}

Rgb8 pixelAt(const TopDownMap& map, const Vec3f& p) {
  const Eigen::Vector2i px = map.toPixel(p);
  EXPECT_GE(px.x(), 0);
  EXPECT_GE(px.y(), 0);
  EXPECT_LT(px.x(), map.width());
  EXPECT_LT(px.y(), map.height());
  const size_t i = (static_cast<size_t>(px.y()) * map.width() + px.x()) * 3;
  return {map.rgb()[i], map.rgb()[i + 1], map.rgb()[i + 2]};
}

class TopDownMapTest : public test::SceneSuite<roomScene> {};

TEST_F(TopDownMapTest, CanvasCoversNavigableAreaWithMargin) {
  TopDownMap map(*scene_, 0.05f);
  // navigable x, z in about [-2.9, 2.9] plus 0.5 m margins at 0.05 m/pixel
  EXPECT_NEAR(map.width(), 136, 6);
  EXPECT_NEAR(map.height(), 136, 6);
  EXPECT_EQ(map.rgb().size(),
            static_cast<size_t>(map.width()) * map.height() * 3);
  // one metre is twenty pixels, x to columns and z to rows
  const Eigen::Vector2i a = map.toPixel({0, 0, 0});
  EXPECT_EQ(map.toPixel({1, 0, 0}) - a, Eigen::Vector2i(20, 0));
  EXPECT_EQ(map.toPixel({0, 0, 1}) - a, Eigen::Vector2i(0, 20));
}

TEST_F(TopDownMapTest, ColoursNavigableObstaclesAndObjects) {
  TopDownMap map(*scene_, 0.05f);
  EXPECT_EQ(pixelAt(map, {-1, 0, 1}), (Rgb8{232, 232, 232}));
  // the cube is drawn in its own (mean vertex) colour
  EXPECT_EQ(pixelAt(map, {2.25f, 0, -0.25f}), (Rgb8{220, 30, 30}));
  // just inside the walls, where the agent's radius keeps it away: obstacle
  // or wall, darker than navigable
  const Rgb8 edge = pixelAt(map, {-2.98f, 0, 0});
  EXPECT_LT(edge[0], 150);
  // beyond the scene's footprint (in the margin): blank
  EXPECT_EQ(pixelAt(map, {-3.2f, 0, -3.2f}), (Rgb8{255, 255, 255}));
}

TEST_F(TopDownMapTest, MarkersDrawnOnTop) {
  TopDownMap map(*scene_, 0.05f);
  const Rgb8 blue{0, 0, 255};
  map.drawPath({Vec3f(-2, 0, 2), Vec3f(-2, 0, -2), Vec3f(0, 0, -2)}, blue, 3);
  EXPECT_EQ(pixelAt(map, {-2, 0, 0}), blue);
  EXPECT_EQ(pixelAt(map, {-1, 0, -2}), blue);
  EXPECT_EQ(pixelAt(map, {-1, 0, 0}), (Rgb8{232, 232, 232}));

  const Rgb8 green{0, 200, 0};
  map.drawPoint({1, 0, 2}, green, 4);
  EXPECT_EQ(pixelAt(map, {1, 0, 2}), green);

  const Rgb8 magenta{255, 0, 255};
  map.drawCircle({0, 0, 1}, 1.0f, magenta, 2);
  EXPECT_EQ(pixelAt(map, {1, 0, 1}), magenta);
  EXPECT_EQ(pixelAt(map, {0, 0, 1}), (Rgb8{232, 232, 232}));
  EXPECT_THROW(map.drawCircle({0, 0, 0}, -1.0f, magenta),
               std::invalid_argument);

  // heading 0 looks along -Z: the arrow points towards smaller rows
  const Rgb8 orange{255, 128, 0};
  map.drawAgent({-1, 0, 1.5f}, 0.0f, orange);
  EXPECT_EQ(pixelAt(map, {-1, 0, 1.5f}), orange);
  EXPECT_EQ(pixelAt(map, {-1, 0, 1.2f}), orange);
  EXPECT_NE(pixelAt(map, {-1, 0, 1.8f}), orange);
  // a left turn of 90 degrees points it along -X
  map.drawAgent({1, 0, -1.5f}, kPi / 2, orange);
  EXPECT_EQ(pixelAt(map, {0.7f, 0, -1.5f}), orange);
  EXPECT_NE(pixelAt(map, {1.3f, 0, -1.5f}), orange);

  map.drawText({-1, 0, -1}, "goal", Rgb8{0, 0, 0});
  int dark = 0;
  for (float dx = -0.3f; dx <= 0.3f; dx += 0.05f)
    for (float dz = -0.1f; dz <= 0.1f; dz += 0.05f)
      if (pixelAt(map, {-1 + dx, 0, -1 + dz})[0] < 100) ++dark;
  EXPECT_GT(dark, 2);
}

TEST_F(TopDownMapTest, ScaleForALongSide) {
  for (int longSide : {64, 800, 1024}) {
    const float mpp =
        TopDownMap::metersPerPixelForLongSide(*scene_, 0.0f, longSide);
    TopDownMap map(*scene_, mpp);
    EXPECT_EQ(std::max(map.width(), map.height()), longSide);
    EXPECT_FLOAT_EQ(map.metersPerPixel(), mpp);
  }
  EXPECT_THAT([&] { TopDownMap::metersPerPixelForLongSide(*scene_, 0.0f, 8); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr(">= 16 pixels")));
}

TEST_F(TopDownMapTest, LabelsBesideTheirObjectNotOnIt) {
  TopDownMap map(*scene_, 0.02f);
  ASSERT_EQ(map.placedLabels().size(), 1u);
  EXPECT_TRUE(map.droppedLabels().empty());
  const MapLabel& label = map.placedLabels()[0];
  EXPECT_EQ(label.text, "table");
  // the cube spans x, z in [1.5, 2.5] x [-0.5, 0.5]
  const Eigen::Vector2i lo = map.toPixel({1.5f, 0, -0.5f});
  const Eigen::Vector2i hi = map.toPixel({2.5f, 0, 0.5f});
  const bool apart = label.x + label.width <= lo.x() || label.x >= hi.x() ||
                     label.y + label.height <= lo.y() || label.y >= hi.y();
  EXPECT_TRUE(apart) << "label at " << label.x << "," << label.y << " size "
                     << label.width << "x" << label.height;
  EXPECT_GE(label.x, 0);
  EXPECT_LE(label.x + label.width, map.width());
  // dark text on a light halo: both inside the label's box
  int dark = 0, light = 0;
  for (int y = label.y; y < label.y + label.height; ++y)
    for (int x = label.x; x < label.x + label.width; ++x) {
      const uint8_t v =
          map.rgb()[(static_cast<size_t>(y) * map.width() + x) * 3];
      dark += v < 60;
      light += v > 240;
    }
  EXPECT_GT(dark, 10);
  EXPECT_GT(light, 10);
  // too small a map for the label anywhere: left out, not drawn over
  TopDownMap tiny(*scene_,
                  TopDownMap::metersPerPixelForLongSide(*scene_, 0.0f, 16));
  EXPECT_TRUE(tiny.placedLabels().empty());
  EXPECT_EQ(tiny.droppedLabels(), std::vector<std::string>{"table"});
}

TEST(TopDownMapFloorTest, DrawsTheFloorNearestToFloorY) {
  // a 4 m x 4 m room at y = 0 and a 2 m x 3 m platform at y = 3 beside it
  TriangleMesh mesh;
  addQuad(mesh, {Vec3f(0, 0, 4), {4, 0, 4}, {4, 0, 0}, {0, 0, 0}},
          Rgb8{200, 200, 200}, -1);
  addWalls(mesh, 0, 4, 0, 4, 0, 2.5f);
  addQuad(mesh, {Vec3f(10, 3, 3), {12, 3, 3}, {12, 3, 0}, {10, 3, 0}},
          Rgb8{200, 200, 200}, -1);
  auto scene =
      Scene::fromMesh("two-floors", std::move(mesh), {}, NavMeshConfig{});
  TopDownMap ground(*scene, 0.05f, 0.0f);
  TopDownMap upper(*scene, 0.05f, 3.2f);
  // widths: navigable extent (minus the agent radius at walls) + 1 m margin
  EXPECT_NEAR(ground.width(), (4.0f - 0.2f + 1.0f) / 0.05f, 6);
  EXPECT_NEAR(upper.width(), (2.0f + 1.0f) / 0.05f, 6);
  EXPECT_NEAR(upper.height(), (3.0f + 1.0f) / 0.05f, 6);
  EXPECT_EQ(pixelAt(upper, {11, 3, 1.5f}), (Rgb8{232, 232, 232}));
}

TEST_F(TopDownMapTest, SavesAPngAtomically) {
  TopDownMap map(*scene_, 0.1f);
  test::TempDir dir;
  const auto file = dir / "maps" / "room.png";
  map.save(file);
  const std::string png = common::readFile(file);
  ASSERT_GT(png.size(), 33u);
  EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  // IHDR: big-endian width and height at bytes 16 and 20
  auto be32 = [&](size_t at) {
    return (static_cast<uint32_t>(static_cast<uint8_t>(png[at])) << 24) |
           (static_cast<uint32_t>(static_cast<uint8_t>(png[at + 1])) << 16) |
           (static_cast<uint32_t>(static_cast<uint8_t>(png[at + 2])) << 8) |
           static_cast<uint32_t>(static_cast<uint8_t>(png[at + 3]));
  };
  EXPECT_EQ(be32(16), static_cast<uint32_t>(map.width()));
  EXPECT_EQ(be32(20), static_cast<uint32_t>(map.height()));
  // no temporary file left beside it
  EXPECT_EQ(vln::test::countEntries(file.parent_path()), 1);
}

TEST_F(TopDownMapTest, RefusesPointsFarOutsideTheScene) {
  // a point at 1e30 overflowed the int pixel coordinates; points are
  // checked as the navmesh checks its queries
  TopDownMap map(*scene_, 0.1f);
  const Vec3f far(1e30f, 0, 0);
  const Vec3f nan(0, 0, NAN);
  const Rgb8 red{255, 0, 0};
  for (const Vec3f& bad : {far, nan}) {
    EXPECT_THROW(map.drawPoint(bad, red), std::invalid_argument);
    EXPECT_THROW(map.drawCircle(bad, 3.0f, red), std::invalid_argument);
    EXPECT_THROW(map.drawAgent(bad, 0.0f, red), std::invalid_argument);
    EXPECT_THROW(map.drawText(bad, "x", red), std::invalid_argument);
    EXPECT_THROW(map.toPixel(bad), std::invalid_argument);
  }
  EXPECT_THAT(
      [&] {
        map.drawPath({Vec3f(1, 0, 1), far}, red);
      },
      ::testing::ThrowsMessage<std::invalid_argument>(
          HasSubstr("TopDownMap::drawPath(): point 1 (1e+30")));
  EXPECT_THAT([&] { map.drawAgent(Vec3f(1, 0, 1), NAN, red); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("TopDownMap::drawAgent(): heading")));
  // off the canvas but near the scene: nothing drawn, no error
  const std::vector<uint8_t> before = map.rgb();
  map.drawPoint(Vec3f(50, 0, 50), red);
  EXPECT_EQ(map.rgb(), before);
}

TEST_F(TopDownMapTest, RejectsBadScale) {
  try {
    TopDownMap map(*scene_, 0.0f);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("metersPerPixel"));
  }
  try {
    TopDownMap map(*scene_, 1e-5f);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("map-room"));
  }
}

}  // namespace
}  // namespace vln::sim
