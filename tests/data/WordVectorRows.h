#pragma once
// Reading a row of a WordVectors table by word, shared by the GloVe tests
// (GloveTest, GloveFitTest).

#include <string_view>
#include <vector>

#include "data/Glove.h"

namespace vln::test {

/// The vector of `word` as a copy, empty when the table has no such word.
inline std::vector<float> row(const data::WordVectors& vectors,
                              std::string_view word) {
  auto index = vectors.find(word);
  if (!index) return {};
  auto span = vectors.vector(*index);
  return {span.begin(), span.end()};
}

}  // namespace vln::test
