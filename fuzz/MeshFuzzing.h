#pragma once
// The one body of the OBJ and PLY fuzz targets: sim::loadScene through
// assimp on the input written as `scene.<extension>`. A mesh the loader
// accepts must pass TriangleMesh::validate(): that is the contract every
// consumer relies on.

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "FuzzUtil.h"
#include "sim/MeshIo.h"

namespace vln::fuzz {

inline void fuzzSceneFile(const std::string& extension, const uint8_t* data,
                          size_t size) {
  auto file = writeInput("scene." + extension, data, size);
  expectDocumentedErrors([&] {
    sim::LoadedScene scene = sim::loadScene(file, {});
    try {
      scene.mesh.validate("fuzz");
    } catch (const std::invalid_argument& e) {
      std::fprintf(stderr, "vln fuzz: loadScene returned an invalid mesh: %s\n",
                   e.what());
      std::abort();
    }
  });
}

}  // namespace vln::fuzz
