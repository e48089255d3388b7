// vlnce-sim: render one view, inspect a navmesh, or measure simulator
// throughput.
//
//   vlnce-sim render --scene F --position x,y,z --heading DEG --out DIR
//       [--backend embree|osmesa] [--width W --height H] [--hfov DEG]
//       [--camera-height M] [--pitch DEG]
//     writes DIR/rgb.png (8-bit RGB) and DIR/depth.png: raw z-depth as a
//     16-bit greyscale PNG in millimetres (0 = nothing hit, saturating at
//     65.535 m). --position is the agent's feet; the eye is --camera-height
//     (VLN-CE: 1.25 m) above it.
//   vlnce-sim navmesh --scene F [--map out.png] [--meters-per-pixel M]
//     prints polygon count, islands with their areas and the navigable area.
//   vlnce-sim bench (--scene F | --procedural SEED) [--res N] [--backend B]
//       [--frames K] [--threads T] [--subdivide N]
//     prints frames/s for RGB, depth and RGB-D at NxN from random navigable
//     poses, and agent steps/s; with --threads, one renderer per thread and
//     the aggregate rate. --subdivide N splits every triangle into N^2
//     (dense meshes for the large-scene target: house 1 with N = 10 has
//     645,800 triangles).

#include <CLI/CLI.hpp>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "common/App.h"
#include "common/Check.h"
#include "common/Progress.h"
#include "sim/MeshIo.h"
#include "sim/RayTracer.h"
#include "sim/Renderer.h"
#include "sim/Scene.h"
#include "sim/Simulator.h"
#include "sim/TopDownMap.h"
#include "world/HouseGenerator.h"

namespace {

using namespace vln;
using namespace vln::sim;
namespace fs = std::filesystem;

// "x,y,z" -> vector; throws naming the option.
Vec3f parseVec3(const std::string& text, const char* option) {
  std::stringstream in(text);
  Vec3f v;
  char comma1 = 0;
  char comma2 = 0;
  in >> v.x() >> comma1 >> v.y() >> comma2 >> v.z();
  VLN_CHECK_ARG(in && comma1 == ',' && comma2 == ',' && (in >> std::ws).eof() &&
                    v.allFinite(),
                option, " expects x,y,z in metres, got '", text,
                "'");
  return v;
}

RendererBackend parseBackend(const std::string& name) {
  if (name == "embree") return RendererBackend::kEmbree;
  if (name == "osmesa") return RendererBackend::kOsMesa;
  throw std::invalid_argument(
      strCat("--backend must be embree or osmesa, got '", name, "'"));
}

// Every triangle split into n x n smaller ones on a barycentric grid
// (edges cut into n pieces); vertex colours and uvs are interpolated and
// per-triangle data inherited, so the images stay the same while the
// triangle count grows n^2-fold (dense meshes for the large-scene target).
TriangleMesh subdivide(const TriangleMesh& mesh, int n) {
  TriangleMesh out;
  out.materials = mesh.materials;
  out.textures = mesh.textures;
  const bool colors = !mesh.colors.empty();
  const bool uvs = !mesh.uvs.empty();
  const float step = 1.0f / static_cast<float>(n);
  std::vector<uint32_t> grid;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    const uint32_t c[3] = {mesh.indices[3 * t], mesh.indices[3 * t + 1],
                           mesh.indices[3 * t + 2]};
    // vertices at barycentric (i/n, j/n) towards corners 1 and 2, i + j <= n
    grid.clear();
    for (int i = 0; i <= n; ++i) {
      for (int j = 0; i + j <= n; ++j) {
        const float b1 = static_cast<float>(i) * step;
        const float b2 = static_cast<float>(j) * step;
        const float b0 = 1.0f - b1 - b2;
        out.positions.push_back(b0 * mesh.positions[c[0]] + b1 * mesh.positions[c[1]] +
                                b2 * mesh.positions[c[2]]);
        if (colors) {
          Rgb8 color;
          for (int k = 0; k < 3; ++k)
            color[k] = static_cast<uint8_t>(std::lround(
                b0 * mesh.colors[c[0]][k] + b1 * mesh.colors[c[1]][k] + b2 * mesh.colors[c[2]][k]));
          out.colors.push_back(color);
        }
        if (uvs)
          out.uvs.push_back(b0 * mesh.uvs[c[0]] + b1 * mesh.uvs[c[1]] + b2 * mesh.uvs[c[2]]);
        grid.push_back(static_cast<uint32_t>(out.positions.size() - 1));
      }
    }
    // row i holds n + 1 - i vertices
    auto at = [&](int i, int j) {
      return grid[static_cast<size_t>(i * (n + 1) - i * (i - 1) / 2 + j)];
    };
    for (int i = 0; i < n; ++i) {
      for (int j = 0; i + j < n; ++j) {
        for (uint32_t index : {at(i, j), at(i + 1, j), at(i, j + 1)})
          out.indices.push_back(index);
        if (i + j + 1 < n)
          for (uint32_t index : {at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)})
            out.indices.push_back(index);
      }
    }
    const size_t pieces = static_cast<size_t>(n) * static_cast<size_t>(n);
    if (!mesh.triangle_material.empty())
      out.triangle_material.insert(out.triangle_material.end(), pieces, mesh.triangle_material[t]);
    if (!mesh.triangle_object.empty())
      out.triangle_object.insert(out.triangle_object.end(), pieces, mesh.triangle_object[t]);
  }
  return out;
}

// ---------------------------------------------------------------------------
// render
// ---------------------------------------------------------------------------

struct RenderArgs {
  std::string scene;
  std::string position;
  float heading = 0.0f;
  float pitch = 0.0f;
  std::string out;
  std::string backend = "embree";
  int width = 256;
  int height = 256;
  float hfov = 90.0f;
  float cameraHeight = 1.25f;
};

int runRender(const RenderArgs& args) {
  const Vec3f feet = parseVec3(args.position, "--position");
  VLN_CHECK_ARG(args.width >= 1 && args.height >= 1 && args.width <= 8192 &&
                    args.height <= 8192,
                "render: --width/--height must be in [1, 8192], got ",
                args.width, "x", args.height);
  // rendering needs the triangles only: no navmesh build
  const LoadedScene loaded = loadScene(args.scene, MeshLoadConfig{});
  const RayTracer tracer(loaded.mesh);
  auto renderer = createRenderer(loaded.mesh, tracer, parseBackend(args.backend));
  const CameraPose pose{feet + Vec3f(0.0f, args.cameraHeight, 0.0f),
                        degToRad(args.heading), degToRad(args.pitch)};
  const CameraIntrinsics camera{args.width, args.height, args.hfov};
  const size_t pixels = static_cast<size_t>(args.width) * args.height;
  std::vector<uint8_t> rgb(pixels * 3);
  std::vector<float> depth(pixels);
  renderer->renderRgbDepth(pose, camera, rgb, depth);
  const fs::path out(args.out);
  saveRgbPng(out / "rgb.png", args.width, args.height, rgb);
  saveDepthPng(out / "depth.png", args.width, args.height, depth);
  size_t hits = 0;
  for (float d : depth) hits += d > 0.0f ? 1 : 0;
  std::printf("wrote %s and %s (%dx%d, %s, %.1f%% of pixels hit)\n",
              (out / "rgb.png").c_str(), (out / "depth.png").c_str(),
              args.width, args.height, args.backend.c_str(),
              100.0 * static_cast<double>(hits) / static_cast<double>(pixels));
  return 0;
}

// ---------------------------------------------------------------------------
// navmesh
// ---------------------------------------------------------------------------

struct NavMeshArgs {
  std::string scene;
  std::string map;
  float metersPerPixel = 0.05f;
  bool noCache = false;
};

int runNavMesh(const NavMeshArgs& args) {
  SimConfig config;
  config.cache_navmesh = !args.noCache;
  const auto scene = Scene::load(args.scene, config);
  const NavMesh& navmesh = scene->navmesh();
  std::printf("scene: %s (%zu triangles)\n", scene->name().c_str(),
              scene->mesh().triangleCount());
  std::printf("polygons: %d\n", navmesh.polygonCount());
  std::printf("islands: %d\n", navmesh.islandCount());
  for (int i = 0; i < navmesh.islandCount(); ++i)
    std::printf("  island %d: %.2f m^2\n", i, navmesh.islandArea(i));
  std::printf("navigable area: %.2f m^2\n", navmesh.navigableArea());
  if (!args.map.empty()) {
    // the map shows the floor of the largest island
    std::mt19937_64 rng(0);
    const Vec3f onFloor = navmesh.randomPoint(rng, /*island=*/0);
    TopDownMap map(*scene, args.metersPerPixel, onFloor.y());
    map.save(args.map);
    std::printf("map: %s (%dx%d)\n", args.map.c_str(), map.width(), map.height());
  }
  return 0;
}

// ---------------------------------------------------------------------------
// bench
// ---------------------------------------------------------------------------

struct BenchArgs {
  std::string scene;
  int64_t procedural = -1;
  int res = 256;
  std::string backend = "embree";
  int frames = 1000;
  int threads = 1;
  int subdivide = 1;
};

enum class Pass { kRgb, kDepth, kRgbDepth };

// CPU seconds used by the whole process (all threads, including llvmpipe's
// rasteriser threads). Frames per CPU-second is the per-core rate, which
// stays meaningful when other jobs share the machine.
double processCpuSeconds() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) + 1e-9 * static_cast<double>(now.tv_nsec);
}

struct Rate {
  double wall = 0.0;  // per wall-clock second, all threads together
  double cpu = 0.0;   // per CPU-second
};

// Frames per second of `pass` over `frames` renders per thread, one
// renderer per thread, all threads starting together.
Rate measurePass(const TriangleMesh& mesh, const RayTracer& tracer,
                 RendererBackend backend,
                   const std::vector<CameraPose>& poses,
                   const CameraIntrinsics& camera, int frames, int threads,
                   Pass pass) {
  std::vector<std::unique_ptr<Renderer>> renderers;
  for (int t = 0; t < threads; ++t)
    renderers.push_back(createRenderer(mesh, tracer, backend));
  std::atomic<int> ready{0};
  std::atomic<bool> go{false};
  auto work = [&](int t) {
    const size_t pixels = static_cast<size_t>(camera.width) * camera.height;
    std::vector<uint8_t> rgb(pixels * 3);
    std::vector<float> depth(pixels);
    Renderer& renderer = *renderers[static_cast<size_t>(t)];
    // warm-up outside the timed region: context, shader variants, caches
    renderer.renderRgbDepth(poses[0], camera, rgb, depth);
    renderer.renderRgb(poses[0], camera, rgb);
    renderer.renderDepth(poses[0], camera, depth);
    ++ready;
    while (!go.load()) std::this_thread::yield();
    for (int f = 0; f < frames; ++f) {
      const CameraPose& pose = poses[(static_cast<size_t>(f) * 7 + t) % poses.size()];
      switch (pass) {
        case Pass::kRgb: renderer.renderRgb(pose, camera, rgb); break;
        case Pass::kDepth: renderer.renderDepth(pose, camera, depth); break;
        case Pass::kRgbDepth: renderer.renderRgbDepth(pose, camera, rgb, depth); break;
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(work, t);
  while (ready.load() < threads) std::this_thread::yield();
  common::Stopwatch clock;
  const double cpuStart = processCpuSeconds();
  go = true;
  for (auto& thread : pool) thread.join();
  const double total = static_cast<double>(frames) * threads;
  return {total / clock.seconds(), total / (processCpuSeconds() - cpuStart)};
}

// Agent steps per second (navmesh moves only, random actions, one
// simulator per thread).
Rate measureSteps(const std::shared_ptr<const Scene>& scene,
                    const std::vector<Vec3f>& starts, int steps, int threads) {
  auto work = [&](int t) {
    SimConfig config;
    Simulator sim(scene, config, TaskConfig{});
    std::mt19937_64 rng(static_cast<uint64_t>(t) + 1);
    std::uniform_int_distribution<int> action(1, 3);
    size_t next = static_cast<size_t>(t);
    sim.reset({starts[next++ % starts.size()], 0.0f});
    for (int s = 0; s < steps; ++s) {
      if (sim.episode().done) sim.reset({starts[next++ % starts.size()], 0.0f});
      sim.step(actionFromInt(action(rng)));
    }
  };
  common::Stopwatch clock;
  const double cpuStart = processCpuSeconds();
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(work, t);
  for (auto& thread : pool) thread.join();
  const double total = static_cast<double>(steps) * threads;
  return {total / clock.seconds(), total / (processCpuSeconds() - cpuStart)};
}

// The 1-minute load average (/proc/loadavg), to judge how many cores the
// measurement really had.
std::string loadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string oneMinute;
  in >> oneMinute;
  return in ? oneMinute : std::string("unknown");
}

int runBench(const BenchArgs& args) {
  VLN_CHECK_ARG(args.scene.empty() != (args.procedural < 0),
                "bench: give exactly one of --scene and --procedural");
  VLN_CHECK_ARG(args.res >= 1 && args.res <= 4096,
                "bench: --res must be in [1, 4096], got ", args.res);
  VLN_CHECK_ARG(args.frames >= 1, "bench: --frames must be >= 1, got ",
                args.frames);
  VLN_CHECK_ARG(args.threads >= 1 && args.threads <= 256,
                "bench: --threads must be in [1, 256], got ", args.threads);
  VLN_CHECK_ARG(args.subdivide >= 1 && args.subdivide <= 64,
                "bench: --subdivide must be in [1, 64], got ",
                args.subdivide);
  const RendererBackend backend = parseBackend(args.backend);

  // scene: a file or a procedural house, optionally subdivided; the navmesh
  // is built from the original triangles (subdivision does not move them)
  common::Stopwatch setup;
  TriangleMesh mesh;
  SceneSemantics semantics;
  std::string name;
  if (!args.scene.empty()) {
    LoadedScene loaded = loadScene(args.scene, MeshLoadConfig{});
    mesh = std::move(loaded.mesh);
    semantics = std::move(loaded.semantics);
    name = fs::path(args.scene).stem().string();
  } else {
    world::House house = world::generateHouse(
        static_cast<uint64_t>(args.procedural), world::HouseConfig{});
    mesh = std::move(house.mesh);
    semantics = std::move(house.semantics);
    name = house.name;
  }
  // the navmesh (poses, agent steps) comes from the original triangles; the
  // renderers trace or rasterise the subdivided ones, which lie on the same
  // surfaces
  const auto scene = Scene::fromMesh(name, mesh, semantics, NavMeshConfig{});
  std::optional<TriangleMesh> dense;
  if (args.subdivide > 1) dense = subdivide(scene->mesh(), args.subdivide);
  const TriangleMesh& rendered = dense ? *dense : scene->mesh();
  common::Stopwatch bvh;
  const RayTracer tracer(rendered);
  const double bvhSeconds = bvh.seconds();
  std::printf("scene: %s, %zu triangles rendered, setup %.2f s (BVH %.2f s)\n",
              name.c_str(), rendered.triangleCount(), setup.seconds(), bvhSeconds);

  // random navigable poses on the main island, eye at VLN-CE's 1.25 m
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<float> heading(-kPi, kPi);
  std::vector<CameraPose> poses;
  std::vector<Vec3f> starts;
  for (int i = 0; i < 256; ++i) {
    const Vec3f p = scene->navmesh().randomPoint(rng, /*island=*/0);
    starts.push_back(p);
    poses.push_back({p + Vec3f(0.0f, 1.25f, 0.0f), heading(rng), 0.0f});
  }

  const char* lpThreads = std::getenv("LP_NUM_THREADS");
  std::printf("backend: %s, %dx%d, %d frames x %d thread(s), LP_NUM_THREADS=%s\n",
              args.backend.c_str(), args.res, args.res, args.frames, args.threads,
              lpThreads ? lpThreads : "(unset)");
  std::printf("load average (1 min) before measuring: %s\n", loadAverage().c_str());
  const CameraIntrinsics camera{args.res, args.res, 90.0f};
  const Rate rgb = measurePass(rendered, tracer, backend, poses, camera, args.frames,
                                 args.threads, Pass::kRgb);
  const Rate depth = measurePass(rendered, tracer, backend, poses, camera, args.frames,
                                   args.threads, Pass::kDepth);
  const Rate rgbd = measurePass(rendered, tracer, backend, poses, camera, args.frames,
                                  args.threads, Pass::kRgbDepth);
  const Rate steps = measureSteps(scene, starts, args.frames * 20, args.threads);
  const double pixels = static_cast<double>(camera.width) * camera.height;
  std::printf("%-6s %14s %16s\n", "", "per wall-second", "per CPU-second");
  std::printf("%-6s %9.1f fps %11.1f fps\n", "RGB", rgb.wall, rgb.cpu);
  // a ray per pixel for Embree; llvmpipe shades the same number of pixels
  std::printf("%-6s %9.1f fps %11.1f fps  (%.1f M%s per CPU-second)\n", "depth",
              depth.wall, depth.cpu, depth.cpu * pixels / 1e6,
              backend == RendererBackend::kEmbree ? "rays" : "pixels");
  std::printf("%-6s %9.1f fps %11.1f fps\n", "RGB-D", rgbd.wall, rgbd.cpu);
  std::printf("%-6s %9.0f /s  %11.0f /s   (agent steps, no rendering)\n", "steps",
              steps.wall, steps.cpu);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return vln::common::runMain("vlnce-sim", [&] {
    CLI::App app{"vlnce-sim: render views, inspect navmeshes, measure throughput"};
    app.require_subcommand(1);

    RenderArgs render;
    auto* renderCmd = app.add_subcommand("render", "Render RGB and depth PNGs of one view");
    renderCmd->add_option("--scene", render.scene, "Scene file (.glb, .obj, .ply)")->required();
    renderCmd->add_option("--position", render.position, "Agent feet x,y,z (m)")->required();
    renderCmd->add_option("--heading", render.heading, "Heading (degrees, 0 = -Z, left positive)")->required();
    renderCmd->add_option("--pitch", render.pitch, "Camera pitch (degrees, up positive)");
    renderCmd->add_option("--out", render.out, "Output directory")->required();
    renderCmd->add_option("--backend", render.backend, "embree or osmesa");
    renderCmd->add_option("--width", render.width, "Image width (pixels)");
    renderCmd->add_option("--height", render.height, "Image height (pixels)");
    renderCmd->add_option("--hfov", render.hfov, "Horizontal field of view (degrees)");
    renderCmd->add_option("--camera-height", render.cameraHeight, "Eye height above the feet (m)");

    NavMeshArgs navmesh;
    auto* navmeshCmd = app.add_subcommand("navmesh", "Build or load a navmesh and describe it");
    navmeshCmd->add_option("--scene", navmesh.scene, "Scene file")->required();
    navmeshCmd->add_option("--map", navmesh.map, "Write a top-down map PNG here");
    navmeshCmd->add_option("--meters-per-pixel", navmesh.metersPerPixel, "Map scale");
    navmeshCmd->add_flag("--no-cache", navmesh.noCache, "Do not read or write <scene>.navmesh");

    BenchArgs bench;
    auto* benchCmd = app.add_subcommand("bench", "Measure rendering and stepping throughput");
    auto* sceneOpt = benchCmd->add_option("--scene", bench.scene, "Scene file");
    auto* proceduralOpt = benchCmd->add_option("--procedural", bench.procedural,
                                               "Procedural house seed");
    sceneOpt->excludes(proceduralOpt);
    benchCmd->add_option("--res", bench.res, "Square image size (pixels)");
    benchCmd->add_option("--backend", bench.backend, "embree or osmesa");
    benchCmd->add_option("--frames", bench.frames, "Frames per thread and pass");
    benchCmd->add_option("--threads", bench.threads, "Renderers in parallel, one per thread");
    benchCmd->add_option("--subdivide", bench.subdivide,
                         "Split every triangle into N x N (edges cut in N)");

    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      return app.exit(e);
    }
    if (*renderCmd) return runRender(render);
    if (*navmeshCmd) return runNavMesh(navmesh);
    return runBench(bench);
  });
}
