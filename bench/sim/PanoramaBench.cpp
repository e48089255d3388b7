// Panorama throughput (issue 18's speed target: at least 100 RGB-D
// panoramas/s of 12 views, depth 256x256 + RGB 224x224, on the 2-core
// machine), against the single-view RGB-D observation of the same cameras
// in the same run. Results and commands: docs/performance.md, section
// "Panoramas".
//
//   build/bin/PanoramaBench --benchmark_min_time=3
//
// Scene: procedural house seed 1, the agent on random navigable points with
// random headings (as RenderBench).

#include <benchmark/benchmark.h>

#include <algorithm>
#include <ctime>
#include <memory>
#include <random>
#include <vector>

#include "sim/Panorama.h"
#include "sim/Scene.h"
#include "sim/Simulator.h"
#include "world/HouseGenerator.h"

namespace {

using namespace vln;
using namespace vln::sim;

constexpr int kPoses = 256;

struct HouseFixture {
  std::shared_ptr<const Scene> scene;
  std::vector<AgentState> states;

  static const HouseFixture& get() {
    static const HouseFixture fixture = [] {
      HouseFixture f;
      world::House house =
          world::generateHouse(/*seed=*/1, world::HouseConfig{});
      f.scene = Scene::fromMesh(house.name, std::move(house.mesh),
                                std::move(house.semantics), NavMeshConfig{});
      f.scene->rayTracer();
      std::mt19937_64 rng(7);
      std::uniform_real_distribution<float> heading(-kPi, kPi);
      for (int i = 0; i < kPoses; ++i)
        f.states.push_back(
            {f.scene->navmesh().randomPoint(rng, /*island=*/0), heading(rng)});
      return f;
    }();
    return fixture;
  }
};

// CPU seconds of the whole process (all threads).
double processCpuSeconds() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) +
         1e-9 * static_cast<double>(now.tv_nsec);
}

// The default sim config: RGB 224x224, depth 256x256, both 90 degrees (the
// default panorama's views are the same cameras); `size` > 0 makes every
// camera size x size instead (the CPU-scale agents of configs/vln/ see
// 64x64).
SimConfig benchConfig(int backend, int size = 0) {
  SimConfig config;
  config.renderer = static_cast<RendererBackend>(backend);
  if (size > 0) {
    config.rgb.width = config.rgb.height = size;
    config.depth.camera.width = config.depth.camera.height = size;
  }
  return config;
}

// The panorama of the same cameras as benchConfig(backend, size).
PanoramaConfig benchPanorama(int threads, int size = 0) {
  const SimConfig sim = benchConfig(0, size);
  PanoramaConfig panorama;
  panorama.rgb = sim.rgb;
  panorama.depth = sim.depth;
  panorama.threads = threads;
  return panorama;
}

// args: backend (0 = Embree, 1 = OSMesa, 2 = the CPU rasteriser; the
// argument keeps its first name, "osmesa", so the commands of
// docs/performance.md keep selecting the same benchmarks), threads of the
// panorama renderer, camera size (0 = the 224 RGB / 256 depth)
void BM_Panorama(benchmark::State& state) {
  const HouseFixture& house = HouseFixture::get();
  Simulator sim(house.scene,
                benchConfig(static_cast<int>(state.range(0)),
                            static_cast<int>(state.range(2))),
                TaskConfig{});
  const PanoramaConfig config = benchPanorama(static_cast<int>(state.range(1)),
                                              static_cast<int>(state.range(2)));
  Panorama panorama;
  sim.reset(house.states[0]);
  sim.observePanorama(config, panorama);  // warm-up: renderers, shading tables
  size_t next = 0;
  const double cpuStart = processCpuSeconds();
  for (auto _ : state) {
    sim.reset(house.states[next++ % house.states.size()]);
    sim.observePanorama(config, panorama);
    benchmark::DoNotOptimize(panorama.depth.data());
    benchmark::DoNotOptimize(panorama.rgb.data());
  }
  const double cpu = processCpuSeconds() - cpuStart;
  state.SetItemsProcessed(state.iterations());  // panoramas/s (wall)
  state.counters["pano/CPU-s"] = benchmark::Counter(
      static_cast<double>(state.iterations()) / std::max(cpu, 1e-9));
  state.counters["views/s"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * panorama.num_views,
      benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Panorama)
    ->ArgNames({"osmesa", "threads", "size"})
    ->ArgsProduct({{0}, {1, 2}, {0, 64}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_Panorama)
    ->ArgNames({"osmesa", "threads", "size"})
    ->Args({1, 1, 0})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_Panorama)
    ->ArgNames({"osmesa", "threads", "size"})
    ->ArgsProduct({{2}, {1, 2}, {0, 64}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
// Two environments side by side, each rendering its own panoramas on one
// thread (what parallel environments of a training run do): the suffix
// ".../threads:2" is Google Benchmark's two copies of the loop, and
// items_per_second their sum.
BENCHMARK(BM_Panorama)
    ->ArgNames({"osmesa", "threads", "size"})
    ->ArgsProduct({{0, 2}, {1}, {0}})
    ->Threads(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The single-view observation of the same two cameras (the low-level
// agents' observation): the panorama ideally costs 12 of these per thread.
void BM_SingleView(benchmark::State& state) {
  const HouseFixture& house = HouseFixture::get();
  Simulator sim(house.scene,
                benchConfig(static_cast<int>(state.range(0)),
                            static_cast<int>(state.range(1))),
                TaskConfig{});
  Observation obs;
  sim.reset(house.states[0]);
  sim.observe(obs);
  size_t next = 0;
  const double cpuStart = processCpuSeconds();
  for (auto _ : state) {
    sim.reset(house.states[next++ % house.states.size()]);
    sim.observe(obs);
    benchmark::DoNotOptimize(obs.depth.data());
  }
  const double cpu = processCpuSeconds() - cpuStart;
  state.SetItemsProcessed(state.iterations());
  state.counters["views/CPU-s"] = benchmark::Counter(
      static_cast<double>(state.iterations()) / std::max(cpu, 1e-9));
}
BENCHMARK(BM_SingleView)
    ->ArgNames({"osmesa", "size"})
    ->ArgsProduct({{0, 1, 2}, {0, 64}})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();

}  // namespace
