// Procedural house speed: houses generated per second (default config, and
// without textures), plus the size of what is generated (triangles and
// objects per house) as counters, and .glb export of one house.

#include <benchmark/benchmark.h>

#include <cstdint>
#include <filesystem>
#include <string>

#include <unistd.h>

#include "sim/MeshIo.h"
#include "sim/SceneSemanticsFile.h"
#include "world/HouseGenerator.h"

namespace vln::world {
namespace {

// One house per iteration, a new seed each time (houses vary in size).
void generate(benchmark::State& state, const HouseConfig& config) {
  uint64_t seed = 0;
  double triangles = 0.0, objects = 0.0, rooms = 0.0;
  for (auto _ : state) {
    House house = generateHouse(seed++, config);
    triangles += static_cast<double>(house.mesh.triangleCount());
    objects += static_cast<double>(house.semantics.objects.size());
    rooms += static_cast<double>(house.semantics.rooms.size());
    benchmark::DoNotOptimize(house);
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["houses/s"] =
      benchmark::Counter(n, benchmark::Counter::kIsRate);
  state.counters["triangles/house"] = triangles / n;
  state.counters["objects/house"] = objects / n;
  state.counters["rooms/house"] = rooms / n;
}

void BM_GenerateHouse(benchmark::State& state) {
  generate(state, HouseConfig{});
}
BENCHMARK(BM_GenerateHouse)->Unit(benchmark::kMillisecond);

void BM_GenerateHouseUntextured(benchmark::State& state) {
  HouseConfig config;
  config.texture_detail = 0.0f;
  generate(state, config);
}
BENCHMARK(BM_GenerateHouseUntextured)->Unit(benchmark::kMillisecond);

void BM_GenerateLargeHouse(benchmark::State& state) {
  HouseConfig config;
  config.min_rooms = 14;
  config.max_rooms = 16;
  config.furniture_density = 1.5f;
  generate(state, config);
}
BENCHMARK(BM_GenerateLargeHouse)->Unit(benchmark::kMillisecond);

void BM_SaveHouseGlb(benchmark::State& state) {
  const House house = generateHouse(1, HouseConfig{});
  const auto file = std::filesystem::temp_directory_path() /
                    ("vln_house_bench_" + std::to_string(::getpid()) + ".glb");
  for (auto _ : state) sim::saveScene(file, house.mesh, house.semantics);
  state.counters["MB"] =
      static_cast<double>(std::filesystem::file_size(file)) / 1e6;
  std::filesystem::remove(file);
  std::filesystem::remove(sim::semanticsPath(file));
}
BENCHMARK(BM_SaveHouseGlb)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace vln::world
