// Fuzzes scene loading of OBJ text (fuzz/MeshFuzzing.h).
#include "MeshFuzzing.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  vln::fuzz::fuzzSceneFile("obj", data, size);
  return 0;
}
