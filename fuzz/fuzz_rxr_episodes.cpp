// Fuzzes the RxR_VLNCE_v0 episode reader (data::readRxrEpisodeFile, .json
// and .json.gz: gzip is detected by its magic bytes), including its NaN
// token rewriting and the RxR instruction fields. An accepted file must
// give every episode an instruction id and a language.
#include <cstdlib>

#include "FuzzUtil.h"
#include "data/RxrEpisodes.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  auto file = vln::fuzz::writeInput("train_guide.json.gz", data, size);
  vln::fuzz::expectDocumentedErrors([&] {
    for (const auto& episode : vln::data::readRxrEpisodeFile(file))
      if (!episode.instruction.instruction_id ||
          episode.instruction.language.empty())
        std::abort();
  });
  return 0;
}
