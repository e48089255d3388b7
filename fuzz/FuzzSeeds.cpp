// fuzz-seeds <dir>: writes the generated seeds of the fuzz corpora that no
// fixture provides, one folder per fuzz target:
//   fuzz_experiment_config/default.yaml  the resolved default run config
//   fuzz_checkpoint/tiny.pth             a checkpoint of two small tensors
//                                        with an Adam state over them
//   fuzz_navmesh/room.navmesh            the navmesh of a 4 m x 3 m room
//                                        with a box in it
//   fuzz_mesh_obj/room.obj               that room exported as OBJ
// scripts/fuzz.sh runs it before fuzzing.
#include <torch/torch.h>

#include <cstdio>
#include <exception>
#include <filesystem>

#include "common/FileIo.h"
#include "sim/MeshIo.h"
#include "sim/NavMesh.h"
#include "train/Checkpoint.h"
#include "train/ExperimentConfig.h"

namespace {

namespace fs = std::filesystem;
using vln::Vec3f;

// appends the quad a-b-c-d (counter-clockwise seen from its front) as two
// triangles
void addQuad(vln::sim::TriangleMesh& mesh, const Vec3f& a, const Vec3f& b,
             const Vec3f& c, const Vec3f& d) {
  auto base = static_cast<uint32_t>(mesh.positions.size());
  for (const Vec3f& p : {a, b, c, d}) mesh.positions.push_back(p);
  for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) mesh.indices.push_back(base + i);
}

void addBox(vln::sim::TriangleMesh& mesh, const Vec3f& lo, const Vec3f& hi) {
  const float x0 = lo.x(), y0 = lo.y(), z0 = lo.z();
  const float x1 = hi.x(), y1 = hi.y(), z1 = hi.z();
  addQuad(mesh, {x0, y1, z1}, {x1, y1, z1}, {x1, y1, z0}, {x0, y1, z0});  // top
  addQuad(mesh, {x0, y0, z1}, {x1, y0, z1}, {x1, y1, z1}, {x0, y1, z1});  // +z
  addQuad(mesh, {x1, y0, z0}, {x0, y0, z0}, {x0, y1, z0}, {x1, y1, z0});  // -z
  addQuad(mesh, {x1, y0, z1}, {x1, y0, z0}, {x1, y1, z0}, {x1, y1, z1});  // +x
  addQuad(mesh, {x0, y0, z0}, {x0, y0, z1}, {x0, y1, z1}, {x0, y1, z0});  // -x
}

vln::sim::TriangleMesh room() {
  vln::sim::TriangleMesh mesh;
  // floor 4 m x 3 m, counter-clockwise seen from above
  addQuad(mesh, {-2.0f, 0.0f, 1.5f}, {2.0f, 0.0f, 1.5f}, {2.0f, 0.0f, -1.5f},
          {-2.0f, 0.0f, -1.5f});
  addBox(mesh, {0.3f, 0.0f, -0.4f}, {0.9f, 0.8f, 0.4f});
  return mesh;
}

void writeSeeds(const fs::path& out) {
  // the resolved default config
  vln::train::ExperimentConfig config;
  vln::common::writeFileAtomic(out / "fuzz_experiment_config" / "default.yaml",
                               vln::train::experimentConfigYaml(config));

  // a checkpoint with real optimizer state
  torch::manual_seed(0);
  torch::Tensor weight = torch::randn({3, 2}, torch::requires_grad());
  torch::Tensor bias = torch::zeros({3}, torch::requires_grad());
  torch::optim::Adam adam({weight, bias}, torch::optim::AdamOptions(1e-3));
  (weight.sum() + bias.sum()).backward();
  adam.step();
  vln::train::Checkpoint checkpoint;
  checkpoint.config_yaml = "trainer:\n  seed: 1\n";
  checkpoint.policy = {{"layer.weight", weight.detach()},
                       {"layer.bias", bias.detach()}};
  checkpoint.optimizer_state = vln::train::serializeOptimizer(adam);
  checkpoint.progress.checkpoint_index = 2;
  checkpoint.progress.stage = "dagger";
  checkpoint.rng_state = "rng";
  vln::train::saveCheckpoint(out / "fuzz_checkpoint" / "tiny.pth", checkpoint);

  // a small room's navmesh and OBJ
  vln::sim::TriangleMesh mesh = room();
  auto navmesh = vln::sim::NavMesh::build(mesh, vln::sim::NavMeshConfig{});
  navmesh->save(out / "fuzz_navmesh" / "room.navmesh");
  vln::sim::saveScene(out / "fuzz_mesh_obj" / "room.obj", mesh);
  // the .mtl beside it is not an input of the OBJ target
  std::error_code ec;
  fs::remove(out / "fuzz_mesh_obj" / "room.mtl", ec);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz-seeds <output dir>\n");
    return 2;
  }
  try {
    writeSeeds(argv[1]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz-seeds: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
