// Fuzzes the ground-truth action reader (data::readGroundTruth).
#include "data/GroundTruth.h"
#include "FuzzUtil.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  auto file = vln::fuzz::writeInput("split_gt.json.gz", data, size);
  vln::fuzz::expectDocumentedErrors([&] { vln::data::readGroundTruth(file); });
  return 0;
}
