#pragma once
// The body of the geometry fuzzer (fuzz/fuzz_geometry.cpp), shared with
// tests/reliability/FuzzCrashersTest.cpp, which replays its crashers.
//
// Where fuzz_mesh_obj and fuzz_mesh_ply mutate file bytes (and mostly meet
// the parsers), this target decodes its input as a recipe of hostile
// geometry, writes it as a *valid* OBJ, PLY (ASCII or binary) or GLB file,
// and drives everything downstream of the parser with it: sim::loadScene,
// the Embree and OSMesa renderers at poses inside and far outside the
// scene, Scene::load's navmesh build (Recast), navmesh queries, agent steps
// and a Simulator episode with observations.
//
// Recipe bytes (reading past the end yields zeros, so every input decodes):
//   [0] file format: OBJ, PLY ASCII, PLY binary, GLB, GLB under a root node
//       transform (byte % 5)
//   [1] import: bit 0 reads Z-up; bits 1-3 pick the scale (kScales);
//       bits 4-5 the navmesh cell size (kCellSizes); bit 6 runs the
//       Simulator with OSMesa instead of Embree
//   [2] number of parts, 1 + byte % 8; then each part: an opcode
//       (Part, byte % kNumParts) and its parameters
//   then the poses (1 + byte % 4), each a kind, a position and a heading;
//   the camera (decodeCamera()); the actions ((byte + 8) % 33 of them,
//   each (byte + 1) % 4).
// Numbers come from Numbers: most bytes give ordinary values, the rest the
// hostile table (0, 1e-30, 1e30, FLT_MAX, inf, NaN, ...). Random parts draw
// through common/Random.h, so that a crasher found by the clang build
// replays as the same scene in the gcc test build.
//
// The oracle is the error policy (src/common/Check.h): every stage may end
// in std::invalid_argument or std::runtime_error (recorded in the report);
// anything else escapes. Extra invariants throw std::logic_error: a loaded
// mesh passes validate(), rendered depth is finite and non-negative, and
// the agent stays at a finite position.

#include <array>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "common/Math.h"
#include "common/Random.h"
#include "sim/Agent.h"
#include "sim/GeometryCheck.h"
#include "sim/MeshIo.h"
#include "sim/NavMesh.h"
#include "sim/RayTracer.h"
#include "sim/Renderer.h"
#include "sim/Scene.h"
#include "sim/Simulator.h"

namespace vln::fuzz::geometry {

namespace fs = std::filesystem;

inline constexpr float kScales[8] = {1.0f,  0.01f, 0.001f, 100.0f,
                                     1e-6f, 1e6f,  0.5f,   1e-7f};
inline constexpr float kCellSizes[4] = {0.05f, 0.1f, 0.25f, 0.5f};
// the navmesh stage is skipped between these grid sizes: such builds take
// seconds under ASan, and the cell limit itself (1e8) is a unit test
inline constexpr double kMaxFuzzedCells = 1e6;
inline constexpr double kRecastCellLimit = 1e8;

/// Bytes -> numbers; zeros past the end.
class Numbers {
 public:
  explicit Numbers(std::string_view bytes) : bytes_(bytes) {}
  uint8_t byte() {
    return pos_ < bytes_.size() ? static_cast<uint8_t>(bytes_[pos_++]) : 0;
  }
  // (the operands of | are unsequenced: read the bytes in two statements)
  uint16_t u16() {
    const uint16_t low = byte();
    return static_cast<uint16_t>(low | (byte() << 8));
  }
  /// Mostly [0, 20) in steps of 1/3200; 1 in 8 a hostile magnitude.
  float magnitude() {
    const uint8_t kind = byte();
    if (kind < 224) return static_cast<float>(u16()) / 3276.8f;
    static constexpr float kHostile[] = {
        0.0f,
        1e-30f,
        1e-12f,
        1e-6f,
        1e-3f,
        0.05f,
        200.0f,
        1e4f,
        1e6f,
        1e7f,
        1e30f,
        FLT_MAX,
        1e-40f,
        std::numeric_limits<float>::infinity(),
        std::numeric_limits<float>::quiet_NaN(),
        3.0f};
    return kHostile[kind % 16];
  }
  /// A signed magnitude around 0.
  float coordinate() {
    const float m = magnitude();
    return (byte() & 1) ? -m : m;
  }
  Vec3f vec() {
    const float x = coordinate();
    const float y = coordinate();
    return {x, y, coordinate()};
  }

 private:
  std::string_view bytes_;
  size_t pos_ = 0;
};

/// Triangles in the file's own frame (whatever axis is up there).
struct FileMesh {
  std::vector<Vec3f> positions;
  std::vector<std::array<uint32_t, 3>> triangles;

  void quad(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d) {
    const auto base = static_cast<uint32_t>(positions.size());
    positions.insert(positions.end(), {a, b, c, d});
    triangles.push_back({base, base + 1, base + 2});
    triangles.push_back({base, base + 2, base + 3});
  }
  // an axis-aligned box, faces outward
  void box(const Vec3f& lo, const Vec3f& hi) {
    const float x0 = lo.x(), y0 = lo.y(), z0 = lo.z();
    const float x1 = hi.x(), y1 = hi.y(), z1 = hi.z();
    quad({x0, y1, z1}, {x1, y1, z1}, {x1, y1, z0}, {x0, y1, z0});
    quad({x0, y0, z0}, {x1, y0, z0}, {x1, y0, z1}, {x0, y0, z1});
    quad({x0, y0, z1}, {x1, y0, z1}, {x1, y1, z1}, {x0, y1, z1});
    quad({x1, y0, z0}, {x0, y0, z0}, {x0, y1, z0}, {x1, y1, z0});
    quad({x1, y0, z1}, {x1, y0, z0}, {x1, y1, z0}, {x1, y1, z1});
    quad({x0, y0, z0}, {x0, y0, z1}, {x0, y1, z1}, {x0, y1, z0});
  }
};

/// Y-up (x, y, z) written as the file's axes: Z-up files store (x, -z, y).
inline Vec3f fileFrame(const Vec3f& yUp, bool zUp) {
  return zUp ? Vec3f(yUp.x(), -yUp.z(), yUp.y()) : yUp;
}

enum Part : uint8_t {
  kBox,            // centre, half sizes
  kFloor,          // a flat quad, Y-up or Z-up as the byte says
  kRoom,           // floor and four walls, Y-up or Z-up
  kTriangle,       // one triangle, any corners
  kDegenerate,     // a repeated corner or three collinear ones
  kSoup,           // up to 32 random triangles in a box
  kTerrain,        // an n x n height grid
  kStairs,         // steps of a given rise and run
  kSpecialVertex,  // one existing vertex becomes a hostile value
  kCopy,           // everything so far again, moved by a vector
  kNumParts
};

inline void decodePart(Numbers& in, FileMesh& mesh) {
  const auto op = static_cast<Part>(in.byte() % kNumParts);
  switch (op) {
    case kBox: {
      const Vec3f c = in.vec();
      // braces: the three reads in order (a constructor call's arguments
      // are evaluated in either order)
      const Vec3f h{in.magnitude(), in.magnitude(), in.magnitude()};
      mesh.box(c - h, c + h);
      return;
    }
    case kFloor: {
      const bool zUp = in.byte() & 1;
      const float y = in.coordinate();
      const float a = in.magnitude(), b = in.magnitude();
      mesh.quad(fileFrame({-a, y, b}, zUp), fileFrame({a, y, b}, zUp),
                fileFrame({a, y, -b}, zUp), fileFrame({-a, y, -b}, zUp));
      return;
    }
    case kRoom: {
      const bool zUp = in.byte() & 1;
      const float a = in.magnitude(), b = in.magnitude(), h = in.magnitude();
      const float t = 0.1f;
      auto box = [&](Vec3f lo, Vec3f hi) {
        const Vec3f p = fileFrame(lo, zUp), q = fileFrame(hi, zUp);
        mesh.box(p.cwiseMin(q), p.cwiseMax(q));
      };
      box({-a, -t, -b}, {a, 0.0f, b});
      box({-a, 0.0f, -b - t}, {a, h, -b});
      box({-a, 0.0f, b}, {a, h, b + t});
      box({-a - t, 0.0f, -b}, {-a, h, b});
      box({a, 0.0f, -b}, {a + t, h, b});
      return;
    }
    case kTriangle: {
      const auto base = static_cast<uint32_t>(mesh.positions.size());
      mesh.positions.insert(mesh.positions.end(),
                            {in.vec(), in.vec(), in.vec()});
      mesh.triangles.push_back({base, base + 1, base + 2});
      return;
    }
    case kDegenerate: {
      const Vec3f a = in.vec(), d = in.vec();
      const bool repeated = in.byte() & 1;
      const auto base = static_cast<uint32_t>(mesh.positions.size());
      mesh.positions.insert(mesh.positions.end(),
                            {a, a + d, repeated ? a : Vec3f(a + 2.0f * d)});
      mesh.triangles.push_back({base, base + 1, base + 2});
      return;
    }
    case kSoup: {
      const Vec3f c = in.vec();
      const float size = in.magnitude();
      std::mt19937_64 rng(in.u16());
      const int count = 1 + in.byte() % 32;
      for (int i = 0; i < count; ++i) {
        const auto base = static_cast<uint32_t>(mesh.positions.size());
        for (int k = 0; k < 3; ++k) {
          const float x = common::uniformRange(rng, -1.0f, 1.0f);
          const float y = common::uniformRange(rng, -1.0f, 1.0f);
          const float z = common::uniformRange(rng, -1.0f, 1.0f);
          mesh.positions.push_back(c + size * Vec3f(x, y, z));
        }
        mesh.triangles.push_back({base, base + 1, base + 2});
      }
      return;
    }
    case kTerrain: {
      const bool zUp = in.byte() & 1;
      const int n = 1 + in.byte() % 48;
      const float size = in.magnitude(), bump = in.magnitude();
      std::mt19937_64 rng(in.u16());
      const auto base = static_cast<uint32_t>(mesh.positions.size());
      for (int i = 0; i <= n; ++i)
        for (int j = 0; j <= n; ++j)
          mesh.positions.push_back(
              fileFrame({size * (static_cast<float>(i) / n - 0.5f),
                         bump * common::uniformRange(rng, 0.0f, 1.0f),
                         size * (0.5f - static_cast<float>(j) / n)},
                        zUp));
      const auto at = [&](int i, int j) {
        return base + static_cast<uint32_t>(i * (n + 1) + j);
      };
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          mesh.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
          mesh.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
      return;
    }
    case kStairs: {
      const int steps = 1 + in.byte() % 16;
      const float rise = in.magnitude(), run = in.magnitude();
      const float width = in.magnitude();
      for (int s = 0; s < steps; ++s)
        mesh.box({run * s, 0.0f, -width},
                 {run * (s + 1), rise * (s + 1), width});
      return;
    }
    case kSpecialVertex: {
      const uint16_t index = in.u16();
      const Vec3f value = in.vec();
      const uint8_t axes = in.byte();
      if (mesh.positions.empty()) return;
      Vec3f& p = mesh.positions[index % mesh.positions.size()];
      for (int k = 0; k < 3; ++k)
        if (axes & (1 << k)) p[k] = value[k];
      return;
    }
    case kCopy: {
      const Vec3f offset = in.vec();
      const auto count = static_cast<uint32_t>(mesh.positions.size());
      const size_t triangles = mesh.triangles.size();
      if (count > 20000) return;
      for (uint32_t v = 0; v < count; ++v)
        mesh.positions.push_back(mesh.positions[v] + offset);
      for (size_t t = 0; t < triangles; ++t) {
        const auto tri = mesh.triangles[t];
        mesh.triangles.push_back(
            {tri[0] + count, tri[1] + count, tri[2] + count});
      }
      return;
    }
    case kNumParts:
      break;
  }
}

// ---------------------------------------------------------------------------
// writers: valid files, whatever the numbers in them
// ---------------------------------------------------------------------------

inline std::string number(float value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.9g", static_cast<double>(value));
  return text;
}

inline void writeText(const fs::path& file, const std::string& text) {
  std::ofstream(file, std::ios::binary) << text;
}

inline void writeObj(const fs::path& file, const FileMesh& mesh) {
  std::string out = "# geometry fuzzer\n";
  for (const Vec3f& p : mesh.positions)
    out +=
        "v " + number(p.x()) + " " + number(p.y()) + " " + number(p.z()) + "\n";
  for (const auto& t : mesh.triangles)
    out += "f " + std::to_string(t[0] + 1) + " " + std::to_string(t[1] + 1) +
           " " + std::to_string(t[2] + 1) + "\n";
  writeText(file, out);
}

inline void writePly(const fs::path& file, const FileMesh& mesh, bool binary) {
  std::string out = "ply\nformat ";
  out += binary ? "binary_little_endian" : "ascii";
  out += " 1.0\nelement vertex " + std::to_string(mesh.positions.size()) +
         "\nproperty float x\nproperty float y\nproperty float z\n"
         "element face " +
         std::to_string(mesh.triangles.size()) +
         "\nproperty list uchar int vertex_indices\nend_header\n";
  auto raw = [&](const void* p, size_t n) {
    out.append(static_cast<const char*>(p), n);
  };
  for (const Vec3f& p : mesh.positions) {
    if (binary)
      raw(p.data(), 12);
    else
      out += number(p.x()) + " " + number(p.y()) + " " + number(p.z()) + "\n";
  }
  for (const auto& t : mesh.triangles) {
    if (binary) {
      const uint8_t three = 3;
      raw(&three, 1);
      for (uint32_t v : t) {
        const auto index = static_cast<int32_t>(v);
        raw(&index, 4);
      }
    } else {
      out += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " +
             std::to_string(t[2]) + "\n";
    }
  }
  writeText(file, out);
}

// Binary glTF 2.0 with one mesh under one node; `matrix` (column-major) is
// that node's transform when given (a Z-up to Y-up root conversion, or a
// hostile one).
inline void writeGlb(const fs::path& file, const FileMesh& mesh,
                     const std::array<float, 16>* matrix) {
  std::string bin;
  for (const Vec3f& p : mesh.positions)
    bin.append(reinterpret_cast<const char*>(p.data()), 12);
  const size_t positionBytes = bin.size();
  for (const auto& t : mesh.triangles)
    bin.append(reinterpret_cast<const char*>(t.data()), 12);
  while (bin.size() % 4) bin.push_back('\0');
  // accessor bounds over the finite values (JSON has no NaN)
  Eigen::AlignedBox3f box;
  for (const Vec3f& p : mesh.positions)
    if (p.allFinite()) box.extend(p);
  std::string bounds;
  if (!box.isEmpty())
    bounds = ",\"min\":[" + number(box.min().x()) + "," +
             number(box.min().y()) + "," + number(box.min().z()) +
             "],\"max\":[" + number(box.max().x()) + "," +
             number(box.max().y()) + "," + number(box.max().z()) + "]";
  std::string node = "{\"mesh\":0,\"name\":\"structure\"";
  if (matrix != nullptr) {
    node += ",\"matrix\":[";
    for (int i = 0; i < 16; ++i) node += (i ? "," : "") + number((*matrix)[i]);
    node += "]";
  }
  node += "}";
  std::string json =
      "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":"
      "[0]}],\"nodes\":[" +
      node +
      "],\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},"
      "\"indices\":1}]}],\"buffers\":[{\"byteLength\":" +
      std::to_string(bin.size()) +
      "}],\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":" +
      std::to_string(positionBytes) +
      "},{\"buffer\":0,\"byteOffset\":" + std::to_string(positionBytes) +
      ",\"byteLength\":" + std::to_string(bin.size() - positionBytes) +
      "}],\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":" +
      std::to_string(mesh.positions.size()) + ",\"type\":\"VEC3\"" + bounds +
      "},{\"bufferView\":1,\"componentType\":5125,\"count\":" +
      std::to_string(3 * mesh.triangles.size()) + ",\"type\":\"SCALAR\"}]}";
  while (json.size() % 4) json.push_back(' ');
  std::string out;
  auto u32 = [&](uint32_t v) {
    out.append(reinterpret_cast<const char*>(&v), 4);
  };
  out += "glTF";
  u32(2);
  u32(static_cast<uint32_t>(12 + 8 + json.size() + 8 + bin.size()));
  u32(static_cast<uint32_t>(json.size()));
  out += "JSON";
  out += json;
  u32(static_cast<uint32_t>(bin.size()));
  out.append("BIN\0", 4);
  out += bin;
  writeText(file, out);
}

// ---------------------------------------------------------------------------
// the run
// ---------------------------------------------------------------------------

/// What one recipe did: the documented errors met on the way, in order.
struct Report {
  std::vector<std::string> errors;
  std::string joined() const {
    std::string all;
    for (const auto& e : errors) all += e + "\n";
    return all;
  }
};

/// Runs `body`; a documented error is recorded and returns false.
template <class Body>
bool stage(Report& report, Body&& body) {
  try {
    body();
    return true;
  } catch (const std::invalid_argument& e) {
    report.errors.emplace_back(e.what());
  } catch (const std::runtime_error& e) {
    report.errors.emplace_back(e.what());
  }
  return false;
}

// A pose of the recipe: a kind (inside the scene, on the navmesh, given,
// or hostile) and a heading.
struct PoseRecipe {
  uint8_t kind = 0;
  Vec3f given = Vec3f::Zero();
  float heading = 0.0f;
};

// The camera: width and height 1-16 and a field of view in [10, 169.4]
// degrees, or for the last six hfov bytes one outside (0, 180) or at its
// edges. Recipes are short and read zeros once they end: zeros give 8 x 8
// at 90 degrees, so that such recipes still render.
inline sim::CameraIntrinsics decodeCamera(Numbers& in) {
  const int width = 1 + (in.byte() + 7) % 16;
  const int height = 1 + (in.byte() + 7) % 16;
  static constexpr float kHostileFov[] = {
      0.0f,
      180.0f,
      std::numeric_limits<float>::quiet_NaN(),
      std::numeric_limits<float>::infinity(),
      1e-6f,
      179.99f};
  const uint8_t f = in.byte();
  const float hfov = f < 250
                         ? 10.0f + static_cast<float>((f + 125) % 250) * 0.64f
                         : kHostileFov[f - 250];
  return {width, height, hfov};
}

inline Vec3f resolvePose(const PoseRecipe& pose,
                         const Eigen::AlignedBox3f& bounds) {
  const float inf = std::numeric_limits<float>::infinity();
  switch (pose.kind % 8) {
    case 0:
      return bounds.center();
    case 1:
      return bounds.min();
    case 2:
      return bounds.max() + Vec3f::Constant(sim::kPoseMargin * 0.999f);
    case 3:
      return bounds.max() + Vec3f::Constant(sim::kPoseMargin * 1.001f);
    case 4:
      return Vec3f(1e30f, 0.0f, 0.0f);
    case 5:
      return Vec3f(inf, -inf, std::numeric_limits<float>::quiet_NaN());
    default:
      return pose.given;
  }
}

inline void checkDepth(const std::vector<float>& depth) {
  for (float d : depth)
    if (!(d >= 0.0f) || !std::isfinite(d))
      throw std::logic_error("geometry fuzzer: rendered depth " + number(d) +
                             " is not finite and >= 0");
}

/// Decodes `bytes`, writes the scene file into `dir` and drives every stage;
/// documented errors land in `report`, anything else escapes.
inline void runRecipe(std::string_view bytes, const fs::path& dir,
                      Report& report) {
  Numbers in(bytes);
  const uint8_t format = in.byte() % 5;
  const uint8_t flags = in.byte();
  sim::SimConfig config;
  config.cache_navmesh = false;
  config.mesh.up_axis = (flags & 1) ? sim::UpAxis::kZ : sim::UpAxis::kY;
  config.mesh.scale = kScales[(flags >> 1) & 7];
  config.navmesh.cell_size = kCellSizes[(flags >> 4) & 3];
  // the simulator's renderer: OSMesa, the rasteriser or Embree
  config.renderer = (flags & 64)    ? sim::RendererBackend::kOsMesa
                    : (flags & 128) ? sim::RendererBackend::kRaster
                                    : sim::RendererBackend::kEmbree;

  // geometry, then what the agent and cameras do
  FileMesh mesh;
  const int parts = 1 + in.byte() % 8;
  for (int i = 0; i < parts; ++i) decodePart(in, mesh);
  std::array<float, 16> matrix{};
  for (int i = 0; i < 16; ++i) matrix[static_cast<size_t>(i)] = (i % 5 == 0);
  if (format == 4) {
    const uint8_t kind = in.byte() % 4;
    if (kind == 1) {  // Z-up to Y-up: -90 degrees about x
      matrix = {1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 0, 0, 0, 1};
    } else if (kind >= 2) {  // any numbers
      for (float& m : matrix) m = in.coordinate();
    }
  }
  std::vector<PoseRecipe> poses(1 + in.byte() % 4);
  for (PoseRecipe& pose : poses) {
    pose.kind = in.byte();
    pose.given = in.vec();
    pose.heading = in.coordinate();
  }
  const sim::CameraIntrinsics camera = decodeCamera(in);
  // zeros (a recipe that ended) give eight MOVE_FORWARDs
  std::vector<sim::Action> actions((in.byte() + 8) % 33);
  for (sim::Action& action : actions)
    action = static_cast<sim::Action>((in.byte() + 1) % sim::kNumActions);
  if (mesh.triangles.empty()) return;

  // the file
  static constexpr const char* kNames[] = {
      "scene.obj", "scene.ply", "scene.ply", "scene.glb", "scene.glb"};
  const fs::path file = dir / kNames[format];
  if (format == 0) writeObj(file, mesh);
  if (format == 1 || format == 2) writePly(file, mesh, format == 2);
  if (format >= 3) writeGlb(file, mesh, format == 4 ? &matrix : nullptr);

  // load
  sim::LoadedScene loaded;
  if (!stage(report, [&] { loaded = sim::loadScene(file, config.mesh); }))
    return;
  try {
    loaded.mesh.validate("geometry fuzzer");
  } catch (const std::invalid_argument& e) {
    throw std::logic_error(std::string("loadScene returned an invalid mesh: ") +
                           e.what());
  }
  const Eigen::AlignedBox3f bounds = loaded.mesh.bounds();

  // every renderer at every pose, and rays from there
  std::unique_ptr<sim::RayTracer> tracer;
  if (stage(report,
            [&] { tracer = std::make_unique<sim::RayTracer>(loaded.mesh); })) {
    for (auto backend : {sim::RendererBackend::kEmbree, sim::RendererBackend::kOsMesa,
                         sim::RendererBackend::kRaster}) {
      std::unique_ptr<sim::Renderer> renderer;
      if (!stage(report, [&] {
            renderer = sim::createRenderer(loaded.mesh, *tracer, backend);
          }))
        continue;
      const size_t pixels = static_cast<size_t>(camera.width) * camera.height;
      std::vector<uint8_t> rgb(pixels * 3);
      std::vector<float> depth(pixels);
      std::vector<int32_t> objects(pixels);
      for (const PoseRecipe& pose : poses) {
        const sim::CameraPose cameraPose{resolvePose(pose, bounds),
                                         pose.heading, pose.heading * 0.25f};
        if (stage(report, [&] {
              renderer->renderRgbDepth(cameraPose, camera, rgb, depth);
            }))
          checkDepth(depth);
        stage(report,
              [&] { renderer->renderSemantic(cameraPose, camera, objects); });
        stage(report, [&] {
          (void)tracer->cast(cameraPose.eye, headingToForward(pose.heading));
          (void)tracer->visible(cameraPose.eye, bounds.center());
        });
      }
    }
  }

  // navmesh: Scene::load imports again and builds (skipping slow grids)
  const double cells = static_cast<double>(bounds.sizes().x()) *
                       bounds.sizes().z() /
                       (config.navmesh.cell_size * config.navmesh.cell_size);
  if (cells > kMaxFuzzedCells && cells <= kRecastCellLimit) return;
  std::shared_ptr<const sim::Scene> scene;
  if (!stage(report, [&] { scene = sim::Scene::load(file, config); })) return;
  const sim::NavMesh& navmesh = scene->navmesh();
  std::mt19937_64 rng(bytes.size());
  for (const PoseRecipe& pose : poses) {
    const Vec3f p = resolvePose(pose, bounds);
    stage(report, [&] { (void)navmesh.snapPoint(p); });
    stage(report, [&] { (void)navmesh.isNavigable(p); });
    stage(report, [&] { (void)navmesh.islandIndex(p); });
    stage(report, [&] { (void)navmesh.distanceToObstacle(p); });
    stage(report, [&] {
      const Vec3f q = navmesh.randomPoint(rng);
      (void)navmesh.geodesicDistance(p, q);
      (void)navmesh.shortestPath(q, p);
      (void)navmesh.moveAlongSurface(q, p);
    });
    // the agent API directly, at that pose
    stage(report, [&] {
      sim::AgentState state{p, pose.heading};
      for (sim::Action action : actions)
        (void)sim::applyAction(navmesh, config.agent, state, action);
    });
  }

  // an episode: reset on the navmesh (or at the first pose), act, observe
  config.rgb = {camera.width, camera.height, 90.0f, 1.25f};
  config.depth.camera = config.rgb;
  std::unique_ptr<sim::Simulator> simulator;
  if (!stage(report, [&] {
        simulator =
            std::make_unique<sim::Simulator>(scene, config, sim::TaskConfig{});
      }))
    return;
  const PoseRecipe& first = poses.front();
  if (!stage(report, [&] {
        const Vec3f start = (first.kind & 8) ? resolvePose(first, bounds)
                                             : navmesh.randomPoint(rng);
        simulator->reset({start, first.heading});
      }))
    return;
  sim::Observation observation;
  stage(report, [&] { simulator->observe(observation); });
  for (sim::Action action : actions) {
    if (simulator->episode().done) break;
    if (!stage(report, [&] {
          simulator->step(action);
          simulator->observe(observation);
        }))
      break;
    if (!simulator->episode().agent.position.allFinite())
      throw std::logic_error(
          "geometry fuzzer: the agent left the finite world");
  }
}

}  // namespace vln::fuzz::geometry
