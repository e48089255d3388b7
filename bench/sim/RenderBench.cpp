// Rendering throughput of both backends (speed targets live here, never in
// unit tests). Results and the commands that produced them are recorded in
// docs/performance.md, section "Simulator".
//
//   build-render/bin/RenderBench --benchmark_min_time=1
//
// Scenes: procedural house seed 1 (VLN-CE's 256x256, 90 degree camera at
// 1.25 m on random navigable poses) and a dense ~650k-triangle scan-like
// terrain for the large-mesh target.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <memory>
#include <random>
#include <vector>

#include "sim/RayTracer.h"
#include "sim/Renderer.h"
#include "sim/Scene.h"
#include "sim/Simulator.h"
#include "world/HouseGenerator.h"

namespace {

using namespace vln;
using namespace vln::sim;
using namespace vln::world;

constexpr int kResolution = 256;
constexpr int kPoses = 256;

// The procedural house and random camera poses on its main island, built
// once per process.
struct HouseFixture {
  std::shared_ptr<const Scene> scene;
  std::vector<CameraPose> poses;
  std::vector<Vec3f> starts;

  static const HouseFixture& get() {
    static const HouseFixture fixture = [] {
      HouseFixture f;
      House house = generateHouse(/*seed=*/1, HouseConfig{});
      f.scene = Scene::fromMesh(house.name, std::move(house.mesh),
                                std::move(house.semantics), NavMeshConfig{});
      f.scene->rayTracer();
      std::mt19937_64 rng(7);
      std::uniform_real_distribution<float> heading(-kPi, kPi);
      for (int i = 0; i < kPoses; ++i) {
        const Vec3f p = f.scene->navmesh().randomPoint(rng, /*island=*/0);
        f.starts.push_back(p);
        f.poses.push_back({p + Vec3f(0.0f, 1.25f, 0.0f), heading(rng), 0.0f});
      }
      return f;
    }();
    return fixture;
  }
};

// A dense, scan-like mesh: a 60 m x 60 m rolling terrain of 570 x 570 quads
// (~650k triangles, ~10 cm cells, the density of an MP3D reconstruction)
// with vertex colours by height.
struct TerrainFixture {
  TriangleMesh mesh;
  std::unique_ptr<RayTracer> tracer;
  std::vector<CameraPose> poses;

  static float height(float x, float z) {
    return 0.6f * std::sin(0.35f * x) * std::cos(0.27f * z) +
           0.15f * std::sin(2.1f * x + 0.7f * z) + 0.05f * std::cos(5.3f * z);
  }

  static const TerrainFixture& get() {
    static const TerrainFixture fixture = [] {
      TerrainFixture f;
      constexpr int kCells = 570;
      constexpr float kSize = 60.0f;
      constexpr float kStep = kSize / kCells;
      for (int j = 0; j <= kCells; ++j) {
        for (int i = 0; i <= kCells; ++i) {
          const float x = i * kStep - kSize / 2;
          const float z = j * kStep - kSize / 2;
          const float y = height(x, z);
          f.mesh.positions.emplace_back(x, y, z);
          const auto shade = static_cast<uint8_t>(std::clamp(128.0f + 120.0f * y, 0.0f, 255.0f));
          f.mesh.colors.push_back({shade, static_cast<uint8_t>(255 - shade), 90});
        }
      }
      for (int j = 0; j < kCells; ++j) {
        for (int i = 0; i < kCells; ++i) {
          const auto a = static_cast<uint32_t>(j * (kCells + 1) + i);
          const uint32_t b = a + 1;
          const auto c = static_cast<uint32_t>(a + kCells + 1);
          const uint32_t d = c + 1;
          for (uint32_t index : {a, c, b, b, c, d}) f.mesh.indices.push_back(index);
        }
      }
      f.tracer = std::make_unique<RayTracer>(f.mesh);
      std::mt19937_64 rng(11);
      std::uniform_real_distribution<float> coord(-25.0f, 25.0f);
      std::uniform_real_distribution<float> heading(-kPi, kPi);
      for (int i = 0; i < kPoses; ++i) {
        const float x = coord(rng);
        const float z = coord(rng);
        // looking slightly down so that most of the image sees the ground
        f.poses.push_back({Vec3f(x, height(x, z) + 1.25f, z), heading(rng), -0.35f});
      }
      return f;
    }();
    return fixture;
  }
};

enum Pass { kRgb = 0, kDepth = 1, kRgbDepth = 2 };

// CPU seconds of the whole process (all threads, including llvmpipe's).
double processCpuSeconds() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) + 1e-9 * static_cast<double>(now.tv_nsec);
}

// Frames per CPU-second: the per-core rate, meaningful even when other jobs
// share the machine (wall-clock rates then only show this process's share).
// With ->Threads(T) every thread reports its frames over the same process
// CPU time and the counters add up to the process total.
void reportCpuRate(benchmark::State& state, double cpuSeconds) {
  state.counters["frames/CPU-s"] = benchmark::Counter(
      static_cast<double>(state.iterations()) / std::max(cpuSeconds, 1e-9));
}

void renderLoop(benchmark::State& state, Renderer& renderer,
                const std::vector<CameraPose>& poses, int pass) {
  const CameraIntrinsics camera{kResolution, kResolution, 90.0f};
  std::vector<uint8_t> rgb(kResolution * kResolution * 3);
  std::vector<float> depth(kResolution * kResolution);
  // warm-up outside the timed loop (OSMesa compiles shader variants lazily)
  renderer.renderRgbDepth(poses[0], camera, rgb, depth);
  renderer.renderRgb(poses[0], camera, rgb);
  renderer.renderDepth(poses[0], camera, depth);
  size_t next = static_cast<size_t>(state.thread_index()) * 31;
  const double cpuStart = processCpuSeconds();
  for (auto _ : state) {
    const CameraPose& pose = poses[next++ % poses.size()];
    switch (pass) {
      case kRgb: renderer.renderRgb(pose, camera, rgb); break;
      case kDepth: renderer.renderDepth(pose, camera, depth); break;
      default: renderer.renderRgbDepth(pose, camera, rgb, depth); break;
    }
    benchmark::DoNotOptimize(rgb.data());
    benchmark::DoNotOptimize(depth.data());
  }
  reportCpuRate(state, processCpuSeconds() - cpuStart);
  // frames/s; with ->Threads(T) the rate is summed over threads
  state.SetItemsProcessed(state.iterations());
  state.counters["Mrays/s"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * kResolution * kResolution / 1e6,
      benchmark::Counter::kIsRate);
}

// args: backend (0 = Embree, 1 = OSMesa), pass
void BM_HouseRender(benchmark::State& state) {
  const HouseFixture& house = HouseFixture::get();
  const auto backend = state.range(0) == 0 ? RendererBackend::kEmbree
                                           : RendererBackend::kOsMesa;
  auto renderer = createRenderer(house.scene->mesh(), house.scene->rayTracer(), backend);
  state.SetLabel(strCat(backend == RendererBackend::kEmbree ? "embree" : "osmesa", " ",
                        house.scene->mesh().triangleCount(), " triangles"));
  renderLoop(state, *renderer, house.poses, static_cast<int>(state.range(1)));
}
BENCHMARK(BM_HouseRender)
    ->ArgNames({"osmesa", "pass"})
    ->ArgsProduct({{0, 1}, {kRgb, kDepth, kRgbDepth}})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();
// one renderer per thread, both cores
BENCHMARK(BM_HouseRender)
    ->ArgNames({"osmesa", "pass"})
    ->ArgsProduct({{0, 1}, {kRgbDepth}})
    ->Threads(2)
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();

void BM_TerrainDepth(benchmark::State& state) {
  const TerrainFixture& terrain = TerrainFixture::get();
  const auto backend = state.range(0) == 0 ? RendererBackend::kEmbree
                                           : RendererBackend::kOsMesa;
  auto renderer = createRenderer(terrain.mesh, *terrain.tracer, backend);
  state.SetLabel(strCat(backend == RendererBackend::kEmbree ? "embree" : "osmesa", " ",
                        terrain.mesh.triangleCount(), " triangles"));
  renderLoop(state, *renderer, terrain.poses, kDepth);
}
BENCHMARK(BM_TerrainDepth)->ArgName("osmesa")->Arg(0)->Arg(1)
    ->Unit(benchmark::kMicrosecond)->UseRealTime();

// agent steps with an RGB-D observation each (the training loop's inner
// step), one simulator per thread
void BM_SimulatorStepObserve(benchmark::State& state) {
  const HouseFixture& house = HouseFixture::get();
  SimConfig config;
  config.rgb = {kResolution, kResolution, 90.0f, 1.25f};
  config.depth.camera = config.rgb;
  config.renderer = state.range(0) == 0 ? RendererBackend::kEmbree
                                        : RendererBackend::kOsMesa;
  Simulator sim(house.scene, config, TaskConfig{});
  std::mt19937_64 rng(static_cast<uint64_t>(state.thread_index()) + 3);
  std::uniform_int_distribution<int> action(1, 3);
  size_t next = 0;
  sim.reset({house.starts[next++], 0.0f});
  Observation obs;
  sim.observe(obs);
  const double cpuStart = processCpuSeconds();
  for (auto _ : state) {
    if (sim.episode().done) sim.reset({house.starts[next++ % house.starts.size()], 0.0f});
    sim.step(actionFromInt(action(rng)));
    sim.observe(obs);
    benchmark::DoNotOptimize(obs.rgb.data());
  }
  reportCpuRate(state, processCpuSeconds() - cpuStart);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_SimulatorStepObserve)->ArgName("osmesa")->Arg(0)->Arg(1)
    ->Unit(benchmark::kMicrosecond)->UseRealTime();
BENCHMARK(BM_SimulatorStepObserve)->ArgName("osmesa")->Arg(0)->Arg(1)->Threads(2)
    ->Unit(benchmark::kMicrosecond)->UseRealTime();

}  // namespace
