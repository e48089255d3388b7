// Fuzzes the GloVe text reader (data::readGloveText). The first input byte
// picks the options: bit 0 asks for dim 3 instead of inferring it, bit 1
// keeps only a few words.
#include "data/Glove.h"
#include "FuzzUtil.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  vln::data::GloveReadOptions options;
  if (data[0] & 1) options.dim = 3;
  if (data[0] & 2)
    options.only_words = std::unordered_set<std::string>{"the", ".", "a b"};
  auto file = vln::fuzz::writeInput("glove.txt", data + 1, size - 1);
  vln::fuzz::expectDocumentedErrors([&] {
    vln::data::WordVectors vectors = vln::data::readGloveText(file, options);
    for (int i = 0; i < vectors.size(); ++i)
      if (static_cast<int>(vectors.vector(i).size()) != vectors.dim())
        std::abort();
  });
  return 0;
}
