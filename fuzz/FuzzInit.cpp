// LLVMFuzzerInitialize of every fuzz target (vln_add_fuzzer compiles this
// file into each): the readers warn on odd but valid input, and logging
// would only slow the fuzzer down.
#include "FuzzUtil.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  vln::fuzz::quietLogging();
  return 0;
}
