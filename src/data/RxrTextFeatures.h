#pragma once
// RxR's precomputed BERT instruction features, as VLN-CE's
// RxRInstructionSensor loads them:
//   <features_dir>/rxr_{split}/{instruction_id:06}_{lang}_text_features.npz
// where features_dir is RxR_VLNCE_v0/text_features and lang is the part of
// the episode's language before '-' ("en-IN" -> "en", "hi-IN" -> "hi"),
// holding the array `features`: [tokens, 768] float32, one row per token.
//
// The loader returns a fixed [512, 768] block: the file's rows first, then
// zero rows after them (padding at the end, with 0.0f, as VLN-CE's
// np.zeros((512, 768)) block does). A file with more than 512 rows keeps
// its first 512 (truncated at the end; VLN-CE would raise there, BERT never
// writes more than 512).

#include <cstdint>
#include <filesystem>
#include <string_view>
#include <vector>

#include "data/Npz.h"

namespace vln::data {

/// Rows of the loaded block (BERT's maximum sequence length).
inline constexpr int kRxrTextTokens = 512;
/// Width of a feature row (BERT-base hidden size).
inline constexpr int kRxrTextFeatureDim = 768;

/// One instruction's features, padded or truncated to `tokens` rows.
struct RxrTextFeatures {
  /// [tokens, dim] float32, row-major; rows past `valid_tokens` are zero.
  std::vector<float> values;
  int tokens = kRxrTextTokens;
  int dim = kRxrTextFeatureDim;
  /// Rows taken from the file: min(file rows, tokens).
  int valid_tokens = 0;
  bool operator==(const RxrTextFeatures&) const = default;
};

/// "en" for "en-US"; the language itself when it has no '-'.
std::string_view rxrLanguagePrefix(std::string_view language);

/// `features_dir / ("rxr_" + split) / "{id:06}_{lang}_text_features.npz"`.
std::filesystem::path rxrTextFeaturesPath(
    const std::filesystem::path& features_dir, std::string_view split,
    int64_t instruction_id, std::string_view language);

/// Loads the `features` array of a text feature file into a [tokens, dim]
/// block (see the file comment). Throws std::runtime_error for a missing or
/// damaged file and std::invalid_argument naming the file for a missing
/// `features` array, a shape other than [n, dim] or non-finite values.
RxrTextFeatures loadRxrTextFeatures(const std::filesystem::path& file,
                                    int tokens = kRxrTextTokens,
                                    int dim = kRxrTextFeatureDim);

/// The features of an episode's instruction: rxrTextFeaturesPath() then
/// loadRxrTextFeatures().
RxrTextFeatures loadRxrTextFeatures(const std::filesystem::path& features_dir,
                                    std::string_view split,
                                    int64_t instruction_id,
                                    std::string_view language);

/// Writes `features` ([n, dim] rows, row-major) as a text feature file
/// (array `features`, np.savez layout), e.g. from a local text encoder.
void writeRxrTextFeatures(const std::filesystem::path& file,
                          const std::vector<float>& features, int dim);

}  // namespace vln::data
