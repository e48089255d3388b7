// Fuzzes scene loading of PLY text (fuzz/MeshFuzzing.h).
#include "MeshFuzzing.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  vln::fuzz::fuzzSceneFile("ply", data, size);
  return 0;
}
