// Fuzzes the checkpoint reader (train::deserializeCheckpoint: LibTorch's zip
// archive + pickled values, then the project's metadata checks). LibTorch
// is uninstrumented: a fault inside it still aborts the run.
#include "train/Checkpoint.h"
#include "FuzzUtil.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string_view bytes(reinterpret_cast<const char*>(data), size);
  vln::fuzz::expectDocumentedErrors(
      [&] { (void)vln::train::deserializeCheckpoint(bytes, "fuzz"); });
  return 0;
}
