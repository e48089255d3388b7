// Fuzzes the .navmesh loader (sim::NavMesh::load, Recast "MSET" tile sets)
// and, on files it accepts, the queries the simulator issues.
#include <random>

#include "sim/NavMesh.h"
#include "FuzzUtil.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  auto file = vln::fuzz::writeInput("scene.navmesh", data, size);
  vln::fuzz::expectDocumentedErrors([&] {
    auto navmesh = vln::sim::NavMesh::load(file);
    (void)navmesh->polygonCount();
    (void)navmesh->navigableArea();
    if (navmesh->islandCount() == 0) return;
    std::mt19937_64 rng(1);
    vln::Vec3f a = navmesh->randomPoint(rng);
    vln::Vec3f b = navmesh->randomPoint(rng);
    (void)navmesh->geodesicDistance(a, b);
    (void)navmesh->moveAlongSurface(a, b);
    (void)navmesh->distanceToObstacle(a);
    (void)navmesh->islandIndex(a);
  });
  return 0;
}
