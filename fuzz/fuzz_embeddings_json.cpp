// Fuzzes the R2R_VLNCE embeddings.json(.gz) reader
// (data::readEmbeddingsJson).
#include "data/Glove.h"
#include "FuzzUtil.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  auto file = vln::fuzz::writeInput("embeddings.json.gz", data, size);
  vln::fuzz::expectDocumentedErrors([&] {
    vln::data::EmbeddingMatrix m = vln::data::readEmbeddingsJson(file);
    // the documented shape invariant every consumer relies on
    if (static_cast<size_t>(m.rows) * static_cast<size_t>(m.dim) !=
        m.values.size())
      std::abort();
  });
  return 0;
}
