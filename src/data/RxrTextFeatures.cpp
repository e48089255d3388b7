#include "data/RxrTextFeatures.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "common/Check.h"

namespace vln::data {

std::string_view rxrLanguagePrefix(std::string_view language) {
  return language.substr(0, language.find('-'));
}

std::filesystem::path rxrTextFeaturesPath(
    const std::filesystem::path& features_dir, std::string_view split,
    int64_t instruction_id, std::string_view language) {
  VLN_CHECK_ARG(instruction_id >= 0, "rxrTextFeaturesPath(): instruction id ",
                instruction_id, " is negative");
  VLN_CHECK_ARG(!language.empty(), "rxrTextFeaturesPath(): instruction ",
                instruction_id, " has no language");
  // Python's {id:06}: zero-padded to at least six digits
  char id[32];
  std::snprintf(id, sizeof id, "%06lld",
                static_cast<long long>(instruction_id));
  return features_dir / strCat("rxr_", split) /
         strCat(id, "_", rxrLanguagePrefix(language), "_text_features.npz");
}

RxrTextFeatures loadRxrTextFeatures(const std::filesystem::path& file,
                                    int tokens, int dim) {
  VLN_ASSERT(tokens > 0 && dim > 0);
  const std::string where =
      strCat("loadRxrTextFeatures(): '", file.string(), "'");
  // other arrays of the file, whatever their dtype, are not parsed
  const NpyArray array = readNpzArray(file, "features");
  VLN_CHECK_ARG(array.shape.size() == 2 && array.shape[1] == dim, where,
                ": array 'features' must be [tokens, ", dim, "], got ",
                array.shape.size(), " dimensions",
                array.shape.size() == 2
                    ? strCat(" [", array.shape[0], ", ", array.shape[1], "]")
                    : std::string());

  // the file's rows first, zero rows after them
  RxrTextFeatures out;
  out.tokens = tokens;
  out.dim = dim;
  out.valid_tokens =
      static_cast<int>(std::min<int64_t>(array.shape[0], tokens));
  out.values.assign(static_cast<size_t>(tokens) * static_cast<size_t>(dim),
                    0.0f);
  const size_t kept =
      static_cast<size_t>(out.valid_tokens) * static_cast<size_t>(dim);
  for (size_t i = 0; i < kept; ++i) {
    VLN_CHECK_ARG(std::isfinite(array.values[i]), where,
                  ": array 'features' has a non-finite value at row ",
                  i / static_cast<size_t>(dim), ", column ",
                  i % static_cast<size_t>(dim));
    out.values[i] = array.values[i];
  }
  return out;
}

RxrTextFeatures loadRxrTextFeatures(const std::filesystem::path& features_dir,
                                    std::string_view split,
                                    int64_t instruction_id,
                                    std::string_view language) {
  return loadRxrTextFeatures(
      rxrTextFeaturesPath(features_dir, split, instruction_id, language));
}

void writeRxrTextFeatures(const std::filesystem::path& file,
                          const std::vector<float>& features, int dim) {
  VLN_CHECK_ARG(dim > 0 && features.size() % static_cast<size_t>(dim) == 0,
                "writeRxrTextFeatures(): '", file.string(),
                "': ", features.size(), " values are not rows of ", dim);
  NpyArray array;
  array.shape = {
      static_cast<int64_t>(features.size() / static_cast<size_t>(dim)), dim};
  array.values = features;
  writeNpz(file, {{"features", std::move(array)}});
}

}  // namespace vln::data
