// LLVMFuzzerInitialize of every fuzz target (vln_add_fuzzer compiles this
// file into each): the readers warn on odd but valid input, and logging
// would only slow the fuzzer down.
#include <cstdlib>

#include "FuzzUtil.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  vln::fuzz::quietLogging();
  // fuzz_geometry renders with OSMesa: llvmpipe's rasteriser threads only
  // cost time on tiny images (read when Mesa loads, so set before any
  // input runs; a value already in the environment wins)
  setenv("LP_NUM_THREADS", "0", /*overwrite=*/0);
  return 0;
}
