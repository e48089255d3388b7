// Fuzzes everything downstream of the scene parsers with hostile geometry
// written as valid OBJ, PLY and GLB files: load, both renderers, the
// navmesh build, navmesh queries, agent steps and a Simulator episode
// (fuzz/GeometryFuzzing.h describes the recipe the input encodes).
#include "FuzzUtil.h"
#include "GeometryFuzzing.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  vln::fuzz::expectDocumentedErrors([&] {
    vln::fuzz::geometry::Report report;
    vln::fuzz::geometry::runRecipe(bytes, vln::fuzz::scratchDir(), report);
  });
  return 0;
}
