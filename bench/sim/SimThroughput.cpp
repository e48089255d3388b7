#include "bench/sim/SimThroughput.h"

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "common/Check.h"
#include "common/Progress.h"
#include "sim/MeshIo.h"
#include "sim/MeshSubdivision.h"
#include "sim/RayTracer.h"
#include "sim/Renderer.h"
#include "sim/Scene.h"
#include "sim/Simulator.h"
#include "world/HouseGenerator.h"

namespace vln::bench {

using namespace vln::sim;
namespace fs = std::filesystem;

namespace {

enum class Pass { kRgb, kDepth, kRgbDepth };

// CPU seconds used by the whole process (all threads, including llvmpipe's
// rasteriser threads). Frames per CPU-second is the per-core rate, which
// stays meaningful when other jobs share the machine.
double processCpuSeconds() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) +
         1e-9 * static_cast<double>(now.tv_nsec);
}

struct Rate {
  double wall = 0.0;  // per wall-clock second, all threads together
  double cpu = 0.0;   // per CPU-second
};

// Frames per second of `pass` over `frames` renders per thread, one
// renderer per thread, all threads starting together.
Rate measurePass(const TriangleMesh& mesh, const RayTracer& tracer,
                 RendererBackend backend, const std::vector<CameraPose>& poses,
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
      const CameraPose& pose =
          poses[(static_cast<size_t>(f) * 7 + t) % poses.size()];
      switch (pass) {
        case Pass::kRgb:
          renderer.renderRgb(pose, camera, rgb);
          break;
        case Pass::kDepth:
          renderer.renderDepth(pose, camera, depth);
          break;
        case Pass::kRgbDepth:
          renderer.renderRgbDepth(pose, camera, rgb, depth);
          break;
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
                  const AgentConfig& agent, const std::vector<Vec3f>& starts,
                  int steps, int threads) {
  auto work = [&](int t) {
    SimConfig config;
    config.agent = agent;
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

}  // namespace

int runSimThroughput(const SimThroughputOptions& options) {
  VLN_CHECK_ARG(options.scene.empty() != (options.procedural < 0),
                "bench: give exactly one of --scene and --procedural");
  VLN_CHECK_ARG(options.res >= 1 && options.res <= 4096,
                "bench: --res must be in [1, 4096], got ", options.res);
  VLN_CHECK_ARG(options.frames >= 1, "bench: --frames must be >= 1, got ",
                options.frames);
  VLN_CHECK_ARG(options.threads >= 1 && options.threads <= 256,
                "bench: --threads must be in [1, 256], got ", options.threads);
  VLN_CHECK_ARG(options.subdivide >= 1 && options.subdivide <= 64,
                "bench: --subdivide must be in [1, 64], got ",
                options.subdivide);
  const RendererBackend backend =
      parseRendererBackend(options.backend, "--backend");

  // scene: a file or a procedural house, optionally subdivided; the navmesh
  // is built from the original triangles (subdivision does not move them)
  common::Stopwatch setup;
  TriangleMesh mesh;
  SceneSemantics semantics;
  std::string name;
  if (!options.scene.empty()) {
    LoadedScene loaded = loadScene(options.scene, options.sim.mesh);
    mesh = std::move(loaded.mesh);
    semantics = std::move(loaded.semantics);
    name = fs::path(options.scene).stem().string();
  } else {
    world::House house = world::generateHouse(
        static_cast<uint64_t>(options.procedural), world::HouseConfig{});
    mesh = std::move(house.mesh);
    semantics = std::move(house.semantics);
    name = house.name;
  }
  // the navmesh (poses, agent steps) comes from the original triangles; the
  // renderers trace or rasterise the subdivided ones, which lie on the same
  // surfaces
  const auto scene =
      Scene::fromMesh(name, mesh, semantics, options.sim.navmesh);
  std::optional<TriangleMesh> dense;
  if (options.subdivide > 1)
    dense = subdivide(scene->mesh(), options.subdivide);
  const TriangleMesh& rendered = dense ? *dense : scene->mesh();
  common::Stopwatch bvh;
  const RayTracer tracer(rendered);
  const double bvhSeconds = bvh.seconds();
  std::printf("scene: %s, %zu triangles rendered, setup %.2f s (BVH %.2f s)\n",
              name.c_str(), rendered.triangleCount(), setup.seconds(),
              bvhSeconds);

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
  std::printf(
      "backend: %s, %dx%d, %d frames x %d thread(s), LP_NUM_THREADS=%s\n",
      options.backend.c_str(), options.res, options.res, options.frames,
      options.threads, lpThreads ? lpThreads : "(unset)");
  std::printf("load average (1 min) before measuring: %s\n",
              loadAverage().c_str());
  const CameraIntrinsics camera{options.res, options.res, 90.0f};
  const Rate rgb = measurePass(rendered, tracer, backend, poses, camera,
                               options.frames, options.threads, Pass::kRgb);
  const Rate depth = measurePass(rendered, tracer, backend, poses, camera,
                                 options.frames, options.threads, Pass::kDepth);
  const Rate rgbd =
      measurePass(rendered, tracer, backend, poses, camera, options.frames,
                  options.threads, Pass::kRgbDepth);
  const Rate steps = measureSteps(scene, options.sim.agent, starts,
                                  options.frames * 20, options.threads);
  const double pixels = static_cast<double>(camera.width) * camera.height;
  std::printf("%-6s %14s %16s\n", "", "per wall-second", "per CPU-second");
  std::printf("%-6s %9.1f fps %11.1f fps\n", "RGB", rgb.wall, rgb.cpu);
  // a ray per pixel for Embree; llvmpipe shades the same number of pixels
  std::printf("%-6s %9.1f fps %11.1f fps  (%.1f M%s per CPU-second)\n", "depth",
              depth.wall, depth.cpu, depth.cpu * pixels / 1e6,
              backend == RendererBackend::kEmbree ? "rays" : "pixels");
  std::printf("%-6s %9.1f fps %11.1f fps\n", "RGB-D", rgbd.wall, rgbd.cpu);
  std::printf("%-6s %9.0f /s  %11.0f /s   (agent steps, no rendering)\n",
              "steps", steps.wall, steps.cpu);
  return 0;
}

}  // namespace vln::bench
