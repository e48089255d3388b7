// Fuzzes the sub-instruction reader (data::readSubInstructions).
#include "data/SubInstructions.h"
#include "FuzzUtil.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  auto file = vln::fuzz::writeInput("train_sub_instructions.json.gz", data, size);
  vln::fuzz::expectDocumentedErrors(
      [&] { vln::data::readSubInstructions(file); });
  return 0;
}
