// Tests src/sim/Renderer.cpp, EmbreeRenderer.cpp, OsMesaRenderer.cpp and
// RasterRenderer.cpp: exact answers on simple geometry for every backend,
// agreement of the backends on a small textured, vertex-coloured room (and,
// for the two that sample pixel centres exactly, a cluttered one), and depth
// post-processing.

#include "sim/Renderer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <barrier>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <random>
#include <thread>
#include <vector>

#include "common/FileIo.h"
#include "sim/GeometryCheck.h"
#include "sim/Mesh.h"
#include "sim/MeshSubdivision.h"
#include "sim/RayTracer.h"
#include "support/TestPaths.h"

namespace vln::sim {
namespace {

using ::testing::HasSubstr;

constexpr RendererBackend kBackends[] = {RendererBackend::kEmbree,
                                         RendererBackend::kOsMesa,
                                         RendererBackend::kRaster};

std::string backendName(RendererBackend backend) {
  return std::string(rendererBackendName(backend));
}

// The class name the backend's errors start with.
std::string backendClassName(RendererBackend backend) {
  switch (backend) {
    case RendererBackend::kEmbree:
      return "EmbreeRenderer";
    case RendererBackend::kOsMesa:
      return "OsMesaRenderer";
    case RendererBackend::kRaster:
      return "RasterRenderer";
  }
  return "";
}

// Appends quad a-b-c-d with per-corner uv and colour, one material and
// object.
void addQuad(TriangleMesh& mesh, const std::array<Vec3f, 4>& corners,
             const std::array<Vec2f, 4>& uvs, const std::array<Rgb8, 4>& colors,
             int material, int object) {
  const auto base = static_cast<uint32_t>(mesh.positions.size());
  for (int k = 0; k < 4; ++k) {
    mesh.positions.push_back(corners[k]);
    mesh.uvs.push_back(uvs[k]);
    mesh.colors.push_back(colors[k]);
  }
  for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) mesh.indices.push_back(base + i);
  for (int t = 0; t < 2; ++t) {
    mesh.triangle_material.push_back(material);
    mesh.triangle_object.push_back(object);
  }
}

constexpr Rgb8 kWhite{255, 255, 255};
const std::array<Rgb8, 4> kAllWhite{kWhite, kWhite, kWhite, kWhite};
const std::array<Vec2f, 4> kNoUv{Vec2f::Zero(), Vec2f::Zero(), Vec2f::Zero(),
                                 Vec2f::Zero()};

// An axis-aligned box as six quads (object `object`, material `material`).
void addBox(TriangleMesh& mesh, const Vec3f& lo, const Vec3f& hi,
            const std::array<Rgb8, 4>& colors, int material, int object) {
  const std::array<Vec2f, 4> uv{Vec2f(0, 1), Vec2f(1, 1), Vec2f(1, 0),
                                Vec2f(0, 0)};
  const float x0 = lo.x(), y0 = lo.y(), z0 = lo.z();
  const float x1 = hi.x(), y1 = hi.y(), z1 = hi.z();
  addQuad(mesh, {Vec3f(x0, y0, z1), {x1, y0, z1}, {x1, y1, z1}, {x0, y1, z1}}, uv, colors, material, object);
  addQuad(mesh, {Vec3f(x1, y0, z0), {x0, y0, z0}, {x0, y1, z0}, {x1, y1, z0}}, uv, colors, material, object);
  addQuad(mesh, {Vec3f(x0, y0, z0), {x0, y0, z1}, {x0, y1, z1}, {x0, y1, z0}}, uv, colors, material, object);
  addQuad(mesh, {Vec3f(x1, y0, z1), {x1, y0, z0}, {x1, y1, z0}, {x1, y1, z1}}, uv, colors, material, object);
  addQuad(mesh, {Vec3f(x0, y1, z1), {x1, y1, z1}, {x1, y1, z0}, {x0, y1, z0}}, uv, colors, material, object);
  addQuad(mesh, {Vec3f(x0, y0, z0), {x1, y0, z0}, {x1, y0, z1}, {x0, y0, z1}}, uv, colors, material, object);
}

// A texture of size x size texels with a smooth pattern plus a checker, so
// bilinear filtering and wrapping both matter.
Texture patternTexture(int size) {
  Texture t;
  t.name = "pattern";
  t.width = size;
  t.height = size;
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const bool checker = ((x / 4) + (y / 4)) % 2 == 0;
      t.rgb.push_back(static_cast<uint8_t>(checker ? 230 : 60 + 4 * x));
      t.rgb.push_back(static_cast<uint8_t>(40 + 6 * y));
      t.rgb.push_back(static_cast<uint8_t>(checker ? 90 : 200));
    }
  }
  return t;
}

// A 6 m x 6 m room (floor y = 0, ceiling y = 3) with a textured floor and
// box, vertex-colour gradients on the walls and two semantic boxes.
TriangleMesh testRoom() {
  TriangleMesh mesh;
  mesh.textures.push_back(patternTexture(32));
  mesh.materials.push_back({"floor", {1.0f, 0.9f, 0.8f}, 0});
  mesh.materials.push_back({"wall", {1.0f, 1.0f, 1.0f}, -1});
  mesh.materials.push_back({"box", {0.8f, 0.7f, 0.9f}, -1});
  mesh.materials.push_back({"textured box", {1.0f, 1.0f, 1.0f}, 0});

  // floor tiles with repeating uv (wrap) and a gentle vertex tint
  for (int i = -3; i < 3; ++i) {
    for (int j = -3; j < 3; ++j) {
      const float x = static_cast<float>(i);
      const float z = static_cast<float>(j);
      addQuad(mesh, {Vec3f(x, 0, z + 1), {x + 1, 0, z + 1}, {x + 1, 0, z}, {x, 0, z}},
              {Vec2f(0.7f * x, 0.7f * (z + 1)), Vec2f(0.7f * (x + 1), 0.7f * (z + 1)),
               Vec2f(0.7f * (x + 1), 0.7f * z), Vec2f(0.7f * x, 0.7f * z)},
              {Rgb8{255, 255, 255}, Rgb8{200, 255, 230}, Rgb8{255, 210, 255},
               Rgb8{230, 230, 180}},
              /*material=*/0, /*object=*/-1);
    }
  }
  // walls with colour gradients from floor to ceiling
  const std::array<Rgb8, 4> wallColors{Rgb8{250, 40, 40}, Rgb8{40, 250, 40},
                                       Rgb8{40, 40, 250}, Rgb8{250, 250, 40}};
  addQuad(mesh, {Vec3f(-3, 0, -3), {3, 0, -3}, {3, 3, -3}, {-3, 3, -3}}, kNoUv, wallColors, 1, -1);
  addQuad(mesh, {Vec3f(3, 0, 3), {-3, 0, 3}, {-3, 3, 3}, {3, 3, 3}}, kNoUv, wallColors, 1, -1);
  addQuad(mesh, {Vec3f(-3, 0, 3), {-3, 0, -3}, {-3, 3, -3}, {-3, 3, 3}}, kNoUv, wallColors, 1, -1);
  addQuad(mesh, {Vec3f(3, 0, -3), {3, 0, 3}, {3, 3, 3}, {3, 3, -3}}, kNoUv, wallColors, 1, -1);
  addQuad(mesh, {Vec3f(-3, 3, -3), {3, 3, -3}, {3, 3, 3}, {-3, 3, 3}}, kNoUv,
          {Rgb8{180, 180, 180}, Rgb8{160, 160, 160}, Rgb8{200, 200, 200}, Rgb8{170, 170, 170}},
          1, -1);
  // furniture
  addBox(mesh, {0.5f, 0.0f, -2.0f}, {1.5f, 0.8f, -1.2f},
         {Rgb8{220, 60, 60}, Rgb8{200, 80, 60}, Rgb8{240, 90, 90}, Rgb8{210, 70, 50}}, 2, 3);
  addBox(mesh, {-2.0f, 0.0f, -1.0f}, {-1.2f, 1.6f, 0.2f}, kAllWhite, 3, 5);
  return mesh;
}

struct Images {
  std::vector<uint8_t> rgb;
  std::vector<float> depth;
  std::vector<int32_t> ids;
};

Images renderAll(Renderer& renderer, const CameraPose& pose,
                 const CameraIntrinsics& camera) {
  const size_t pixels = static_cast<size_t>(camera.width) * camera.height;
  Images images{std::vector<uint8_t>(pixels * 3), std::vector<float>(pixels),
                 std::vector<int32_t>(pixels)};
  renderer.renderRgbDepth(pose, camera, images.rgb, images.depth);
  renderer.renderSemantic(pose, camera, images.ids);
  return images;
}

// Pixels at or next to a depth discontinuity in either image, where the two
// rasterisation rules may legitimately pick different surfaces. Inverse
// depth is linear in screen space on a plane, so its second difference is
// ~0 inside any flat surface and large across a silhouette; a hit next to a
// miss counts as well. The edge is widened by one pixel.
std::vector<bool> silhouetteMask(const std::vector<float>& a,
                                 const std::vector<float>& b, int width,
                                 int height) {
  std::vector<bool> edge(a.size(), false);
  auto at = [&](const std::vector<float>& image, int x, int y) {
    x = std::clamp(x, 0, width - 1);
    y = std::clamp(y, 0, height - 1);
    return image[static_cast<size_t>(y) * width + x];
  };
  for (const auto* image : {&a, &b}) {
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        const float d = at(*image, x, y);
        const float nx0 = at(*image, x - 1, y), nx1 = at(*image, x + 1, y);
        const float ny0 = at(*image, x, y - 1), ny1 = at(*image, x, y + 1);
        bool isEdge = false;
        for (float n : {nx0, nx1, ny0, ny1})
          if ((n > 0.0f) != (d > 0.0f)) isEdge = true;
        if (!isEdge && d > 0.0f) {
          const float inv = 1.0f / d;
          const float secondX = std::abs(1.0f / nx0 - 2.0f * inv + 1.0f / nx1);
          const float secondY = std::abs(1.0f / ny0 - 2.0f * inv + 1.0f / ny1);
          isEdge = std::max(secondX, secondY) > 0.02f * inv + 0.002f;
        }
        if (isEdge) edge[static_cast<size_t>(y) * width + x] = true;
      }
    }
  }
  std::vector<bool> mask(a.size(), false);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int qx = std::clamp(x + dx, 0, width - 1);
          const int qy = std::clamp(y + dy, 0, height - 1);
          if (edge[static_cast<size_t>(qy) * width + qx])
            mask[static_cast<size_t>(y) * width + x] = true;
        }
  return mask;
}

// ---------------------------------------------------------------------------
// exact answers
// ---------------------------------------------------------------------------

class RendererBackendTest : public ::testing::TestWithParam<RendererBackend> {};

INSTANTIATE_TEST_SUITE_P(Backends, RendererBackendTest,
                         ::testing::ValuesIn(kBackends),
                         [](const auto& info) {
                           return std::string(backendName(info.param));
                         });

TEST_P(RendererBackendTest, WallTwoMetresAwayHasDepthTwoEverywhere) {
  TriangleMesh mesh;
  addQuad(mesh, {Vec3f(-50, -50, -2), {50, -50, -2}, {50, 50, -2}, {-50, 50, -2}},
          kNoUv, kAllWhite, -1, 4);
  mesh.triangle_material.clear();
  RayTracer tracer(mesh);
  auto renderer = createRenderer(mesh, tracer, GetParam());
  // a non-square image and an eye away from the origin
  const CameraIntrinsics camera{64, 40, 90.0f};
  CameraPose pose;
  pose.eye = {3.0f, 1.5f, 0.0f};
  std::vector<float> depth(64 * 40);
  renderer->renderDepth(pose, camera, depth);
  for (size_t p = 0; p < depth.size(); ++p)
    ASSERT_NEAR(depth[p], 2.0f, 1e-4f) << "pixel " << p;
  std::vector<int32_t> ids(64 * 40);
  renderer->renderSemantic(pose, camera, ids);
  for (int32_t id : ids) ASSERT_EQ(id, 4);
}

TEST_P(RendererBackendTest, FloorDepthMatchesAnalyticPerPixel) {
  TriangleMesh mesh;
  addQuad(mesh, {Vec3f(-500, 0, 500), {500, 0, 500}, {500, 0, -500}, {-500, 0, -500}},
          kNoUv, kAllWhite, -1, -1);
  mesh.triangle_material.clear();
  RayTracer tracer(mesh);
  auto renderer = createRenderer(mesh, tracer, GetParam());
  const CameraIntrinsics camera{48, 64, 70.0f};
  CameraPose pose;
  pose.eye = {0.3f, 1.25f, -0.7f};
  pose.heading = 0.6f;
  pose.pitch = -0.35f;
  std::vector<float> depth(48 * 64);
  renderer->renderDepth(pose, camera, depth);
  const Eigen::Matrix3f rotation = cameraToWorld(pose);
  int checked = 0;
  for (int row = 0; row < camera.height; ++row) {
    for (int col = 0; col < camera.width; ++col) {
      // camera-frame direction has z = -1, so the ray parameter to the floor
      // is the z-depth
      const Vec3f dir = rotation * pixelDirection(camera, static_cast<float>(col),
                                                  static_cast<float>(row));
      const float expected = dir.y() < 0.0f ? pose.eye.y() / -dir.y() : 0.0f;
      const float got = depth[static_cast<size_t>(row) * camera.width + col];
      if (expected == 0.0f || expected > 100.0f) {
        // above the horizon, or beyond the floor's edge
        continue;
      }
      ASSERT_NEAR(got, expected, 1e-4f * expected) << "row " << row << " col " << col;
      ++checked;
    }
  }
  // the pitch puts most of the image on the floor
  EXPECT_GT(checked, 48 * 64 / 2);
  // rows looking up see nothing: depth 0
  EXPECT_EQ(depth[0], 0.0f);
}

TEST_P(RendererBackendTest, ColourIsBaseTimesVertexColourTimesTexture) {
  // an 8x8 texture made of four 4x4 blocks; uv (0,0) at the wall's top left,
  // so the image's first row appears at the top, as glTF defines it
  Texture texture;
  texture.width = 8;
  texture.height = 8;
  const Rgb8 blocks[2][2] = {{Rgb8{255, 0, 0}, Rgb8{0, 255, 0}},
                             {Rgb8{0, 0, 255}, Rgb8{255, 255, 255}}};
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x)
      for (uint8_t c : blocks[y / 4][x / 4]) texture.rgb.push_back(c);
  TriangleMesh mesh;
  mesh.textures.push_back(texture);
  mesh.materials.push_back({"tex", {1.0f, 0.5f, 1.0f}, 0});
  mesh.materials.push_back({"plain", {0.5f, 1.0f, 1.0f}, -1});
  // left: textured wall, vertex colour (255, 255, 128)
  const Rgb8 tint{255, 255, 128};
  addQuad(mesh, {Vec3f(-2, -1, -1), {0, -1, -1}, {0, 1, -1}, {-2, 1, -1}},
          {Vec2f(0, 1), Vec2f(1, 1), Vec2f(1, 0), Vec2f(0, 0)},
          {tint, tint, tint, tint}, 0, 1);
  // right: plain wall, vertex colour (200, 100, 50)
  const Rgb8 plain{200, 100, 50};
  addQuad(mesh, {Vec3f(0, -1, -1), {2, -1, -1}, {2, 1, -1}, {0, 1, -1}}, kNoUv,
          {plain, plain, plain, plain}, 1, 2);
  RayTracer tracer(mesh);
  auto renderer = createRenderer(mesh, tracer, GetParam());
  // 90 degrees at 1 m sees exactly x, y in [-1, 1]
  const CameraIntrinsics camera{80, 80, 90.0f};
  std::vector<uint8_t> rgb(80 * 80 * 3);
  renderer->renderRgb(CameraPose{}, camera, rgb);
  auto pixel = [&](int col, int row) {
    const uint8_t* p = &rgb[(static_cast<size_t>(row) * 80 + col) * 3];
    return Rgb8{p[0], p[1], p[2]};
  };
  auto expectNear = [](Rgb8 got, Rgb8 want, const char* where) {
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(got[c], want[c], 1) << where << " channel " << c;
  };
  // texture blocks (x in [-1, 0] covers u in [0.5, 1]): top-right quarter of
  // the texture is green, bottom-right white
  // green (0,255,0) x base (1,.5,1) x tint (1,1,128/255)
  expectNear(pixel(20, 20), Rgb8{0, 128, 0}, "textured top");
  // white x base x tint = (255, 128, 128)
  expectNear(pixel(20, 60), Rgb8{255, 128, 128}, "textured bottom");
  // plain: (200,100,50) x (0.5,1,1)
  expectNear(pixel(60, 20), Rgb8{100, 100, 50}, "plain top");
  expectNear(pixel(60, 60), Rgb8{100, 100, 50}, "plain bottom");
  std::vector<int32_t> ids(80 * 80);
  renderer->renderSemantic(CameraPose{}, camera, ids);
  EXPECT_EQ(ids[20 * 80 + 20], 1);
  EXPECT_EQ(ids[60 * 80 + 60], 2);
}

TEST_P(RendererBackendTest, HeadingAndPitchFollowTheAgentConvention) {
  // one marker quad on each side of the camera; heading +90 deg (a left
  // turn) must bring the one on the left (-X) into view, pitch +90 deg the
  // one above
  TriangleMesh mesh;
  auto marker = [&](const Vec3f& centre, const Vec3f& u, const Vec3f& v, int object) {
    addQuad(mesh, {centre - u - v, centre + u - v, centre + u + v, centre - u + v},
            kNoUv, kAllWhite, -1, object);
  };
  marker({-3, 0, 0}, {0, 0, 1}, {0, 1, 0}, 10);  // left
  marker({3, 0, 0}, {0, 0, 1}, {0, 1, 0}, 11);   // right
  marker({0, 3, 0}, {1, 0, 0}, {0, 0, 1}, 12);   // above
  marker({0, 0, -3}, {1, 0, 0}, {0, 1, 0}, 13);  // ahead
  mesh.triangle_material.clear();
  RayTracer tracer(mesh);
  auto renderer = createRenderer(mesh, tracer, GetParam());
  const CameraIntrinsics camera{16, 16, 60.0f};
  std::vector<int32_t> ids(16 * 16);
  auto centreId = [&](float heading, float pitch) {
    renderer->renderSemantic(CameraPose{Vec3f::Zero(), heading, pitch}, camera, ids);
    return ids[8 * 16 + 8];
  };
  EXPECT_EQ(centreId(0.0f, 0.0f), 13);
  EXPECT_EQ(centreId(kPi / 2, 0.0f), 10);
  EXPECT_EQ(centreId(-kPi / 2, 0.0f), 11);
  EXPECT_EQ(centreId(0.0f, kPi / 2 - 0.01f), 12);
}

TEST_P(RendererBackendTest, RejectsWrongBuffersAndIntrinsics) {
  TriangleMesh mesh = testRoom();
  RayTracer tracer(mesh);
  auto renderer = createRenderer(mesh, tracer, GetParam());
  std::vector<uint8_t> rgb(10);
  try {
    renderer->renderRgb(CameraPose{}, CameraIntrinsics{4, 4, 90.0f}, rgb);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("renderRgb()"));
    EXPECT_THAT(e.what(), HasSubstr("48"));
  }
  std::vector<float> depth(16);
  EXPECT_THROW(renderer->renderDepth(CameraPose{}, CameraIntrinsics{4, 4, 180.0f}, depth),
               std::invalid_argument);
  EXPECT_THROW(renderer->renderDepth(CameraPose{Vec3f(NAN, 0, 0), 0, 0},
                                     CameraIntrinsics{4, 4, 90.0f}, depth),
               std::invalid_argument);
  // headings and pitches too: the camera's rotation is built from them
  for (const CameraPose& pose : {CameraPose{Vec3f(1, 1, 1), NAN, 0},
                                 CameraPose{Vec3f(1, 1, 1), 0, INFINITY}})
    EXPECT_THAT(
        [&] {
          renderer->renderDepth(pose, CameraIntrinsics{4, 4, 90.0f}, depth);
        },
        ::testing::ThrowsMessage<std::invalid_argument>(
            HasSubstr("camera pose must be finite")));
  std::vector<float> none;
  EXPECT_THROW(renderer->renderDepth(CameraPose{}, CameraIntrinsics{0, 4, 90.0f}, none),
               std::invalid_argument);
}

TEST_P(RendererBackendTest, CamerasFarOutsideTheSceneAreRefused) {
  // `vlnce-sim render --position 1e30,0,0` aborted inside Embree (an
  // assertion on the ray); every public method refuses such an eye
  TriangleMesh mesh = testRoom();
  RayTracer tracer(mesh);
  auto renderer = createRenderer(mesh, tracer, GetParam());
  const CameraIntrinsics camera{4, 4, 90.0f};
  std::vector<uint8_t> rgb(48);
  std::vector<float> depth(16);
  std::vector<int32_t> ids(16);
  const Eigen::AlignedBox3f bounds = mesh.bounds();
  for (const Vec3f& eye :
       {Vec3f(1e30f, 0, 0), Vec3f(0, -1e20f, 0),
        Vec3f(bounds.max().x() + kPoseMargin + 1.0f, 0, 0)}) {
    const CameraPose pose{eye, 0.0f, 0.0f};
    EXPECT_THAT(
        [&] { renderer->renderRgbDepth(pose, camera, rgb, depth); },
        ::testing::ThrowsMessage<std::invalid_argument>(
            ::testing::AllOf(HasSubstr(backendClassName(GetParam()) +
                                       "::renderRgbDepth(): camera eye"),
                             HasSubstr("outside the scene"))));
    EXPECT_THROW(renderer->renderRgb(pose, camera, rgb), std::invalid_argument);
    EXPECT_THROW(renderer->renderDepth(pose, camera, depth),
                 std::invalid_argument);
    EXPECT_THROW(renderer->renderSemantic(pose, camera, ids),
                 std::invalid_argument);
  }
  // just inside the margin: an ordinary (empty) view
  const CameraPose outside{
      Vec3f(bounds.max().x() + kPoseMargin - 1.0f, 1.0f, 0.0f), 0.0f, 0.0f};
  renderer->renderDepth(outside, camera, depth);
  for (float d : depth) EXPECT_GE(d, 0.0f);
}

TEST_P(RendererBackendTest, RenderersOnSeveralThreadsRunConcurrently) {
  // the multi-threading model of the panorama renderer: one renderer per
  // thread at any moment, over one shared mesh and ray tracer, the renderers
  // changing threads between rounds (a pool hands them to whichever thread
  // is free). Colour and depth are both read back: OSMesa's contexts once
  // crashed here, in the depth read-back of two threads at once.
  TriangleMesh mesh = testRoom();
  RayTracer tracer(mesh);
  const CameraIntrinsics camera{48, 40, 90.0f};
  const size_t pixels = static_cast<size_t>(camera.width) * camera.height;
  std::vector<CameraPose> poses;
  for (int i = 0; i < 6; ++i)
    poses.push_back({Vec3f(-1.0f + 0.4f * i, 1.25f, 1.0f), 0.9f * i, -0.1f});
  auto reference = createRenderer(mesh, tracer, GetParam());
  std::vector<std::vector<uint8_t>> expectedRgb;
  std::vector<std::vector<float>> expectedDepth;
  for (const CameraPose& pose : poses) {
    expectedRgb.emplace_back(pixels * 3);
    reference->renderRgb(pose, camera, expectedRgb.back());
    expectedDepth.emplace_back(pixels);
    reference->renderDepth(pose, camera, expectedDepth.back());
  }
  constexpr int kThreads = 2;
  std::vector<std::unique_ptr<Renderer>> renderers;
  for (int t = 0; t < kThreads; ++t)
    renderers.push_back(createRenderer(mesh, tracer, GetParam()));
  std::vector<int> mismatches(kThreads, 0);
  std::barrier roundDone(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      std::vector<uint8_t> rgb(pixels * 3);
      std::vector<float> depth(pixels);
      for (int round = 0; round < 20; ++round) {
        Renderer& renderer =
            *renderers[static_cast<size_t>((t + round) % kThreads)];
        for (size_t i = 0; i < poses.size(); ++i) {
          renderer.renderRgb(poses[i], camera, rgb);
          renderer.renderDepth(poses[i], camera, depth);
          if (rgb != expectedRgb[i] || depth != expectedDepth[i])
            ++mismatches[static_cast<size_t>(t)];
        }
        roundDone.arrive_and_wait();
      }
    });
  }
  for (auto& thread : threads) thread.join();
  EXPECT_EQ(mismatches, std::vector<int>(kThreads, 0));
}

TEST_P(RendererBackendTest, ImageSizeMayChangeBetweenRenders) {
  TriangleMesh mesh = testRoom();
  RayTracer tracer(mesh);
  auto renderer = createRenderer(mesh, tracer, GetParam());
  const CameraPose pose{Vec3f(0, 1.25f, 1), 0.3f, 0.0f};
  for (CameraIntrinsics camera : {CameraIntrinsics{32, 32, 90.0f},
                                  CameraIntrinsics{37, 23, 75.0f},
                                  CameraIntrinsics{32, 32, 90.0f}}) {
    std::vector<float> depth(static_cast<size_t>(camera.width) * camera.height);
    renderer->renderDepth(pose, camera, depth);
    // inside a closed room every pixel hits within the room's diagonal
    for (float d : depth) {
      ASSERT_GT(d, 0.0f);
      ASSERT_LT(d, 9.0f);
    }
  }
}

// ---------------------------------------------------------------------------
// backend agreement
// ---------------------------------------------------------------------------

TEST(RendererAgreementTest, EmbreeAndOsMesaAgreeOnTestRoom) {
  TriangleMesh mesh = testRoom();
  RayTracer tracer(mesh);
  auto embree = createRenderer(mesh, tracer, RendererBackend::kEmbree);
  auto osmesa = createRenderer(mesh, tracer, RendererBackend::kOsMesa);
  const std::vector<std::pair<CameraPose, CameraIntrinsics>> views = {
      {{Vec3f(0, 1.25f, 2), 0.0f, 0.0f}, {96, 96, 90.0f}},
      {{Vec3f(0.4f, 1.25f, 1.5f), 0.5f, -0.3f}, {128, 72, 90.0f}},
      {{Vec3f(-0.5f, 1.0f, 0.5f), 2.4f, 0.2f}, {64, 96, 70.0f}},
      {{Vec3f(2.0f, 0.5f, 2.0f), 0.8f, -0.1f}, {96, 96, 110.0f}},
      {{Vec3f(1.0f, 1.25f, 0.0f), -1.9f, -0.6f}, {80, 80, 90.0f}},
  };
  for (const auto& [pose, camera] : views) {
    SCOPED_TRACE(::testing::Message() << "heading " << pose.heading << " pitch "
                                      << pose.pitch << " size " << camera.width
                                      << "x" << camera.height);
    const Images a = renderAll(*embree, pose, camera);
    const Images b = renderAll(*osmesa, pose, camera);
    const auto silhouette = silhouetteMask(a.depth, b.depth, camera.width, camera.height);

    // depth: median over all pixels, tail over non-silhouette pixels
    std::vector<float> diffs;
    size_t interior = 0;
    size_t allWithin = 0;
    size_t within5cm = 0;
    size_t idMatches = 0;
    double colorError = 0.0;
    size_t colorWithin = 0;
    for (size_t p = 0; p < a.depth.size(); ++p) {
      const float diff = std::abs(a.depth[p] - b.depth[p]);
      diffs.push_back(diff);
      if (diff < 0.05f) ++allWithin;
      if (silhouette[p]) continue;
      ++interior;
      if (diff < 0.05f) ++within5cm;
      if (a.ids[p] == b.ids[p]) ++idMatches;
      int worst = 0;
      for (int c = 0; c < 3; ++c) {
        const int d = std::abs(int(a.rgb[3 * p + c]) - int(b.rgb[3 * p + c]));
        colorError += d;
        worst = std::max(worst, d);
      }
      if (worst <= 3) ++colorWithin;
    }
    std::nth_element(diffs.begin(), diffs.begin() + diffs.size() / 2, diffs.end());
    const float median = diffs[diffs.size() / 2];
    EXPECT_LT(median, 0.01f);
    ASSERT_GT(interior, a.depth.size() * 8 / 10);
    EXPECT_GE(static_cast<double>(within5cm), 0.99 * interior);
    // silhouettes themselves mostly agree too: both sample pixel centres
    EXPECT_GE(static_cast<double>(allWithin), 0.99 * a.depth.size());
    EXPECT_GE(static_cast<double>(idMatches), 0.995 * interior);
    // colour: bilinear weights in llvmpipe are 8-bit fixed point, so a level
    // or two of difference is expected; the mean stays well under one level
    EXPECT_LT(colorError / (3.0 * interior), 0.5);
    EXPECT_GE(static_cast<double>(colorWithin), 0.995 * interior);
  }
}

// The test room with each triangle cut into 16 and 400 small triangles of
// random size, orientation, colour and uv strewn through it, crossing each
// other and the walls: many small, overlapping and hidden triangles.
TriangleMesh clutteredRoom() {
  TriangleMesh mesh = subdivide(testRoom(), 4);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> coordinate(-2.8f, 2.8f);
  std::uniform_real_distribution<float> height(0.1f, 2.9f);
  std::uniform_real_distribution<float> offset(-0.3f, 0.3f);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::uniform_int_distribution<int> channel(0, 255);
  for (int t = 0; t < 400; ++t) {
    const Vec3f centre(coordinate(rng), height(rng), coordinate(rng));
    const auto base = static_cast<uint32_t>(mesh.positions.size());
    for (int k = 0; k < 3; ++k) {
      mesh.positions.push_back(centre +
                               Vec3f(offset(rng), offset(rng), offset(rng)));
      mesh.uvs.emplace_back(3.0f * unit(rng), 3.0f * unit(rng));
      mesh.colors.push_back(Rgb8{static_cast<uint8_t>(channel(rng)),
                                 static_cast<uint8_t>(channel(rng)),
                                 static_cast<uint8_t>(channel(rng))});
    }
    for (uint32_t k = 0; k < 3; ++k) mesh.indices.push_back(base + k);
    mesh.triangle_material.push_back(t % 4);
    mesh.triangle_object.push_back(100 + t);
  }
  return mesh;
}

TEST(RendererAgreementTest, RasterAndEmbreeAgreeAtPixelCentres) {
  // both decide per pixel centre whether its ray meets a triangle in front
  // of the eye and take the nearest, so they may differ only where rounding
  // settles a centre on a triangle's edge (or two surfaces' depths)
  // differently. Poses look everywhere in the rooms, some from a few
  // centimetres off a wall (triangles crossing the eye's plane).
  for (const bool cluttered : {false, true}) {
    SCOPED_TRACE(cluttered ? "cluttered room" : "test room");
    const TriangleMesh mesh = cluttered ? clutteredRoom() : testRoom();
    RayTracer tracer(mesh);
    auto embree = createRenderer(mesh, tracer, RendererBackend::kEmbree);
    auto raster = createRenderer(mesh, tracer, RendererBackend::kRaster);
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> coordinate(-2.9f, 2.9f);
    std::uniform_real_distribution<float> height(0.2f, 2.8f);
    std::uniform_real_distribution<float> angle(-3.2f, 3.2f);
    std::vector<CameraPose> poses;
    for (int i = 0; i < 30; ++i)
      poses.push_back({Vec3f(coordinate(rng), height(rng), coordinate(rng)),
                       angle(rng), 0.4f * angle(rng)});
    poses.push_back({Vec3f(0.0f, 1.25f, -2.97f), 0.0f, 0.0f});
    poses.push_back({Vec3f(2.98f, 1.0f, 0.0f), 1.3f, 0.1f});
    poses.push_back({Vec3f(1.0f, 0.81f, -1.6f), 2.0f, -0.7f});
    size_t pixels = 0, hitMismatches = 0, depthMismatches = 0, idMismatches = 0,
           colorMismatches = 0, colorOffByMore = 0;
    for (const CameraIntrinsics& camera :
         {CameraIntrinsics{61, 47, 90.0f}, CameraIntrinsics{64, 64, 90.0f},
          CameraIntrinsics{37, 53, 120.0f}}) {
      for (const CameraPose& pose : poses) {
        const Images a = renderAll(*embree, pose, camera);
        const Images b = renderAll(*raster, pose, camera);
        for (size_t p = 0; p < a.depth.size(); ++p) {
          ++pixels;
          if ((a.depth[p] > 0.0f) != (b.depth[p] > 0.0f)) ++hitMismatches;
          if (std::abs(a.depth[p] - b.depth[p]) > 1e-5f * a.depth[p])
            ++depthMismatches;
          if (a.ids[p] != b.ids[p]) ++idMismatches;
          int worst = 0;
          for (int c = 0; c < 3; ++c)
            worst = std::max(
                worst, std::abs(int(a.rgb[3 * p + c]) - int(b.rgb[3 * p + c])));
          if (worst > 0) ++colorMismatches;
          if (worst > 1) ++colorOffByMore;
        }
      }
    }
    SCOPED_TRACE(::testing::Message()
                 << pixels << " pixels: " << hitMismatches << " hit, "
                 << depthMismatches << " depth, " << idMismatches << " object, "
                 << colorMismatches << " colour mismatches, " << colorOffByMore
                 << " by more than a level");
    EXPECT_LE(hitMismatches, pixels / 10000);
    EXPECT_LE(depthMismatches, pixels / 2000);
    EXPECT_LE(idMismatches, pixels / 2000);
    EXPECT_LE(colorMismatches, pixels / 1000);
    EXPECT_LE(colorOffByMore, pixels / 10000);
  }
}

TEST(EmbreeRendererTest, PacketAndPortablePathsRenderTheSameBits) {
  // the vector paths (AVX-512 ray set-up and shading, AVX2 shading, where
  // the CPU has them) and the portable paths fuse the same multiply-adds in
  // the same order, so a machine's vector units never change an image, and
  // with it the features and weights trained on it.
  // The room's floor and box are textured with wrap, its walls are vertex
  // colour gradients; poses look everywhere in it.
  TriangleMesh mesh = testRoom();
  RayTracer tracer(mesh);
  auto fast = createRenderer(mesh, tracer, RendererBackend::kEmbree);
  ASSERT_EQ(::setenv("VLN_EMBREE_SHADING", "scalar", /*overwrite=*/1), 0);
  auto portable = createRenderer(mesh, tracer, RendererBackend::kEmbree);
  ASSERT_EQ(::unsetenv("VLN_EMBREE_SHADING"), 0);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coordinate(-2.9f, 2.9f);
  std::uniform_real_distribution<float> height(0.2f, 2.8f);
  std::uniform_real_distribution<float> angle(-3.2f, 3.2f);
  for (const CameraIntrinsics& camera :
       {CameraIntrinsics{61, 47, 90.0f}, CameraIntrinsics{64, 64, 90.0f},
        CameraIntrinsics{37, 53, 120.0f}}) {
    for (int i = 0; i < 40; ++i) {
      const CameraPose pose{
          Vec3f(coordinate(rng), height(rng), coordinate(rng)), angle(rng),
          0.4f * angle(rng)};
      const size_t pixels = static_cast<size_t>(camera.width) * camera.height;
      std::vector<uint8_t> rgbA(3 * pixels), rgbB(3 * pixels);
      std::vector<float> depthA(pixels), depthB(pixels);
      fast->renderRgbDepth(pose, camera, rgbA, depthA);
      portable->renderRgbDepth(pose, camera, rgbB, depthB);
      ASSERT_EQ(rgbA, rgbB)
          << "pose " << i << " at " << camera.width << "x" << camera.height;
      ASSERT_EQ(
          0, std::memcmp(depthA.data(), depthB.data(), pixels * sizeof(float)))
          << "pose " << i << " at " << camera.width << "x" << camera.height;
    }
  }
}

// ---------------------------------------------------------------------------
// OSMesa context handling
// ---------------------------------------------------------------------------

TEST(OsMesaRendererTest, RendersFromAnotherThreadAndInterleavedRenderers) {
  TriangleMesh room = testRoom();
  TriangleMesh wall;
  addQuad(wall, {Vec3f(-50, -50, -2), {50, -50, -2}, {50, 50, -2}, {-50, 50, -2}},
          kNoUv, kAllWhite, -1, -1);
  wall.triangle_material.clear();
  RayTracer roomTracer(room);
  RayTracer wallTracer(wall);
  auto first = createRenderer(room, roomTracer, RendererBackend::kOsMesa);
  auto second = createRenderer(wall, wallTracer, RendererBackend::kOsMesa);
  const CameraIntrinsics camera{40, 30, 90.0f};
  const CameraPose pose{Vec3f(0, 1.25f, 1), 0.4f, -0.1f};
  std::vector<float> reference(40 * 30);
  first->renderDepth(pose, camera, reference);

  // interleaving two contexts on one thread must switch between them
  std::vector<float> wallDepth(40 * 30);
  std::vector<float> again(40 * 30);
  second->renderDepth(CameraPose{}, camera, wallDepth);
  first->renderDepth(pose, camera, again);
  EXPECT_EQ(again, reference);
  for (float d : wallDepth) ASSERT_NEAR(d, 2.0f, 1e-4f);

  // a renderer moves to another thread (used there, never concurrently)
  std::vector<float> fromThread(40 * 30);
  std::thread worker([&] { first->renderDepth(pose, camera, fromThread); });
  worker.join();
  EXPECT_EQ(fromThread, reference);
  first->renderDepth(pose, camera, again);
  EXPECT_EQ(again, reference);
}

// ---------------------------------------------------------------------------
// postprocessDepth
// ---------------------------------------------------------------------------

TEST(PostprocessDepthTest, ClipsMissesAndNormalises) {
  DepthCameraConfig config;  // VLN-CE: MIN_DEPTH 0, MAX_DEPTH 10, normalised
  std::vector<float> depth = {0.0f, 2.5f, 10.0f, 12.0f, NAN};
  postprocessDepth(config, depth);
  EXPECT_THAT(depth, ::testing::ElementsAre(1.0f, 0.25f, 1.0f, 1.0f, 1.0f));

  config.min_depth = 0.5f;
  config.max_depth = 4.5f;
  config.normalize_depth = false;
  depth = {0.0f, 0.1f, 2.0f, 7.0f};
  postprocessDepth(config, depth);
  EXPECT_THAT(depth, ::testing::ElementsAre(4.5f, 0.5f, 2.0f, 4.5f));

  config.normalize_depth = true;
  depth = {0.0f, 0.1f, 2.5f, 7.0f};
  postprocessDepth(config, depth);
  EXPECT_THAT(depth, ::testing::ElementsAre(1.0f, 0.0f, 0.5f, 1.0f));

  config.min_depth = 5.0f;
  config.max_depth = 5.0f;
  try {
    postprocessDepth(config, depth);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("min_depth"));
  }
}

// ---------------------------------------------------------------------------
// PNG output
// ---------------------------------------------------------------------------

// PNG IHDR fields: width, height, bit depth and colour type.
struct PngHeader {
  uint32_t width = 0;
  uint32_t height = 0;
  int bitDepth = 0;
  int colorType = 0;
};

PngHeader readPngHeader(const std::filesystem::path& file) {
  const std::string png = common::readFile(file);
  EXPECT_GT(png.size(), 33u);
  EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  auto byte = [&](size_t at) { return static_cast<uint32_t>(static_cast<uint8_t>(png[at])); };
  auto be32 = [&](size_t at) {
    return byte(at) << 24 | byte(at + 1) << 16 | byte(at + 2) << 8 | byte(at + 3);
  };
  return {be32(16), be32(20), static_cast<int>(byte(24)), static_cast<int>(byte(25))};
}

TEST(ImagePngTest, WritesRgbAndSixteenBitDepth) {
  test::TempDir dir;
  std::vector<uint8_t> rgb(5 * 3 * 3, 128);
  saveRgbPng(dir / "rgb.png", 5, 3, rgb);
  const PngHeader color = readPngHeader(dir / "rgb.png");
  EXPECT_EQ(color.width, 5u);
  EXPECT_EQ(color.height, 3u);
  EXPECT_EQ(color.bitDepth, 8);
  EXPECT_EQ(color.colorType, 2);  // truecolour

  std::vector<float> depth(5 * 3, 1.25f);
  depth[0] = 0.0f;
  depth[1] = 100.0f;
  saveDepthPng(dir / "out" / "depth.png", 5, 3, depth);
  const PngHeader grey = readPngHeader(dir / "out" / "depth.png");
  EXPECT_EQ(grey.width, 5u);
  EXPECT_EQ(grey.bitDepth, 16);
  EXPECT_EQ(grey.colorType, 0);  // greyscale

  try {
    saveRgbPng(dir / "bad.png", 4, 3, rgb);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("saveRgbPng()"));
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "bad.png"));
}

TEST(ParseRendererBackendTest, NamesEveryBackendAndRejectsOthers) {
  for (const RendererBackend backend : kBackends)
    EXPECT_EQ(parseRendererBackend(rendererBackendName(backend), "--backend"),
              backend);
  EXPECT_EQ(rendererBackendName(RendererBackend::kRaster), "raster");
  try {
    parseRendererBackend("Embree", "--backend");
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(),
                 "--backend must be embree, osmesa or raster, got 'Embree'");
  }
}

TEST(CameraModelTest, PixelDirectionsAndRotation) {
  const CameraIntrinsics square{4, 4, 90.0f};
  // pixel centres at (i + 0.5): the corner pixel is 3/4 of the way out
  EXPECT_TRUE(pixelDirection(square, 0, 0).isApprox(Vec3f(-0.75f, 0.75f, -1.0f)));
  EXPECT_TRUE(pixelDirection(square, 3, 3).isApprox(Vec3f(0.75f, -0.75f, -1.0f)));
  // non-square: the vertical extent follows the aspect ratio
  const CameraIntrinsics wide{8, 4, 90.0f};
  EXPECT_NEAR(tanHalfVerticalFov(wide), 0.5f, 1e-6f);
  EXPECT_TRUE(pixelDirection(wide, 0, 0).isApprox(Vec3f(-0.875f, 0.375f, -1.0f)));
  // heading rotates the view like the agent (Math.h), pitch tilts it up
  CameraPose pose;
  pose.heading = 0.7f;
  EXPECT_TRUE((cameraToWorld(pose) * Vec3f(0, 0, -1)).isApprox(headingToForward(0.7f)));
  pose.pitch = 0.3f;
  const Vec3f forward = cameraToWorld(pose) * Vec3f(0, 0, -1);
  EXPECT_NEAR(forward.y(), std::sin(0.3f), 1e-6f);
  EXPECT_NEAR(forwardToHeading(forward), 0.7f, 1e-6f);
}

}  // namespace
}  // namespace vln::sim
