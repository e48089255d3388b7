// Fuzzes the R2R_VLNCE episode reader (data::readEpisodes, .json and
// .json.gz: gzip is detected by its magic bytes).
#include "data/Episode.h"
#include "FuzzUtil.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  auto file = vln::fuzz::writeInput("episodes.json.gz", data, size);
  vln::fuzz::expectDocumentedErrors([&] { vln::data::readEpisodes(file); });
  return 0;
}
