// Fuzzes scene loading of OBJ text (sim::loadScene through assimp, via a
// file in a private directory). A mesh the loader accepts must pass
// TriangleMesh::validate(): that is the contract every consumer relies on.
#include "sim/MeshIo.h"
#include "FuzzUtil.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  vln::fuzz::quietLogging();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  auto file = vln::fuzz::writeInput("scene.obj", data, size);
  vln::fuzz::expectDocumentedErrors([&] {
    vln::sim::LoadedScene scene = vln::sim::loadScene(file, {});
    try {
      scene.mesh.validate("fuzz");
    } catch (const std::invalid_argument& e) {
      std::fprintf(stderr, "vln fuzz: loadScene returned an invalid mesh: %s\n",
                   e.what());
      std::abort();
    }
  });
  return 0;
}
