#include "rollout/ObservationBatch.h"

#include <torch/torch.h>

#include <algorithm>
#include <cstring>

#include "common/Check.h"
#include "data/RxrTextFeatures.h"
#include "data/SubInstructions.h"
#include "data/Vocabulary.h"
#include "world/ViewLabels.h"

namespace vln::rollout {

ObservationBatch batchObservations(const VectorEnv& envs,
                                   std::span<const int> active,
                                   const models::ModelConfig& model) {
  const auto n = static_cast<int64_t>(active.size());
  ObservationBatch batch;
  if (model.usesRgb()) {
    batch.rgb =
        torch::empty({n, model.rgb_height, model.rgb_width, 3}, torch::kUInt8);
    const size_t bytes =
        static_cast<size_t>(model.rgb_height) * model.rgb_width * 3;
    for (int64_t k = 0; k < n; ++k) {
      const auto& obs = envs.observation(active[static_cast<size_t>(k)]);
      VLN_CHECK_ARG(obs.rgb_width == model.rgb_width &&
                        obs.rgb_height == model.rgb_height,
                    "batchObservations(): RGB observation is ", obs.rgb_width,
                    "x", obs.rgb_height,
                    " but model.rgb_width x model.rgb_height is ",
                    model.rgb_width, "x", model.rgb_height);
      std::memcpy(
          batch.rgb.data_ptr<uint8_t>() + k * static_cast<int64_t>(bytes),
          obs.rgb.data(), bytes);
    }
  }
  if (model.usesDepth()) {
    batch.depth = torch::empty({n, model.depth_height, model.depth_width, 1},
                               torch::kFloat32);
    const size_t count =
        static_cast<size_t>(model.depth_height) * model.depth_width;
    for (int64_t k = 0; k < n; ++k) {
      const auto& obs = envs.observation(active[static_cast<size_t>(k)]);
      VLN_CHECK_ARG(obs.depth_width == model.depth_width &&
                        obs.depth_height == model.depth_height,
                    "batchObservations(): depth observation is ",
                    obs.depth_width, "x", obs.depth_height,
                    " but model.depth_width x model.depth_height is ",
                    model.depth_width, "x", model.depth_height);
      std::memcpy(
          batch.depth.data_ptr<float>() + k * static_cast<int64_t>(count),
          obs.depth.data(), count * sizeof(float));
    }
  }
  return batch;
}

torch::Tensor batchInstructions(std::span<const data::Episode* const> episodes,
                                int maxLength) {
  VLN_CHECK_ARG(maxLength >= 1, "batchInstructions(): maxLength must be >= 1");
  int64_t longest = 1;
  for (const auto* episode : episodes)
    longest = std::max<int64_t>(
        longest,
        std::min(maxLength, data::unpaddedLength(
                                episode->instruction.instruction_tokens)));
  auto tokens = torch::zeros({static_cast<int64_t>(episodes.size()), longest},
                             torch::kInt64);
  auto access = tokens.accessor<int64_t, 2>();
  for (size_t k = 0; k < episodes.size(); ++k) {
    const auto& source = episodes[k]->instruction.instruction_tokens;
    // R2R pads on the right; copy real tokens up to the first PAD
    for (int64_t j = 0; j < longest && j < static_cast<int64_t>(source.size());
         ++j) {
      if (source[static_cast<size_t>(j)] == 0) break;
      access[static_cast<int64_t>(k)][j] = source[static_cast<size_t>(j)];
    }
  }
  return tokens;
}

torch::Tensor batchRuleClauses(std::span<const data::Episode* const> episodes,
                               int64_t width) {
  VLN_CHECK_ARG(width >= 1, "batchRuleClauses(): width must be >= 1");
  auto out = torch::full({static_cast<int64_t>(episodes.size()), width}, -1,
                         torch::kInt64);
  auto access = out.accessor<int64_t, 2>();
  for (size_t k = 0; k < episodes.size(); ++k) {
    const auto row = static_cast<int64_t>(k);
    for (const data::SubInstructionTokens& c :
         data::ruleClauses(episodes[k]->instruction.instruction_text))
      for (int64_t j = c.first; j < std::min<int64_t>(c.last, width); ++j)
        access[row][j] = c.leg;
  }
  return out;
}

torch::Tensor batchGoalLabels(std::span<const data::Episode* const> episodes) {
  auto out = torch::zeros(
      {static_cast<int64_t>(episodes.size()), world::viewLabelSize()});
  for (size_t k = 0; k < episodes.size(); ++k) {
    const std::vector<float> row =
        world::goalLabels(episodes[k]->instruction.instruction_text);
    std::memcpy(out[static_cast<int64_t>(k)].data_ptr<float>(), row.data(),
                row.size() * sizeof(float));
  }
  return out;
}

InstructionFeatureSource rxrTextFeatureSource(
    const std::filesystem::path& featuresDir, const std::string& split,
    int dim) {
  return [featuresDir, split, dim](const data::Episode& episode) {
    VLN_CHECK_ARG(episode.instruction.instruction_id.has_value(),
                  "rxrTextFeatureSource(): episode ", episode.episode_id,
                  " has no instruction.instruction_id, which names its text "
                  "feature file (not an RxR_VLNCE episode?)");
    // the loader checks the width (model.text_feature_dim) and names the
    // file; the episode is added here, with the error's type kept (a
    // missing file is I/O, a bad one invalid input)
    const std::filesystem::path file = data::rxrTextFeaturesPath(
        featuresDir, split, *episode.instruction.instruction_id,
        episode.instruction.language);
    const std::string context =
        strCat("text features of episode ", episode.episode_id, " (split '",
               split, "', instruction_id ", *episode.instruction.instruction_id,
               ", ", episode.instruction.language, "): ");
    if (!std::filesystem::exists(file))
      throw std::runtime_error(strCat(
          context, "'", file.string(),
          "' does not exist (dataset.text_features_dir; made by trainer.task "
          "text_mlm, docs/rxr_text.md)"));
    data::RxrTextFeatures features;
    try {
      features = data::loadRxrTextFeatures(file, data::kRxrTextTokens, dim);
    } catch (const std::invalid_argument& error) {
      throw std::invalid_argument(context + error.what());
    } catch (const std::runtime_error& error) {
      throw std::runtime_error(context + error.what());
    }
    // the file's rows only: the zero rows after them are padding
    const int64_t rows = std::max(features.valid_tokens, 1);
    return torch::from_blob(const_cast<float*>(features.values.data()),
                            {rows, features.dim}, torch::kFloat32)
        .clone();
  };
}

void requireRxrTextFeatureFiles(
    const std::filesystem::path& featuresDir, const std::string& split,
    std::span<const data::Episode* const> episodes) {
  std::string first;
  size_t missing = 0;
  for (const data::Episode* episode : episodes) {
    VLN_CHECK_ARG(episode->instruction.instruction_id.has_value(),
                  "requireRxrTextFeatureFiles(): episode ", episode->episode_id,
                  " of split '", split,
                  "' has no instruction.instruction_id, which names its text "
                  "feature file (not an RxR_VLNCE episode?)");
    const std::filesystem::path file = data::rxrTextFeaturesPath(
        featuresDir, split, *episode->instruction.instruction_id,
        episode->instruction.language);
    if (std::filesystem::exists(file)) continue;
    if (missing++ == 0)
      first = strCat("'", file.string(), "' (episode ", episode->episode_id,
                     ", instruction_id ", *episode->instruction.instruction_id,
                     ")");
  }
  VLN_CHECK_IO(missing == 0, "text features of split '", split, "': ", missing,
               " of ", episodes.size(), " files are missing, the first ", first,
               " (dataset.text_features_dir; made by trainer.task text_mlm, "
               "docs/rxr_text.md)");
}

torch::Tensor instructionFeatures(const InstructionFeatureSource& source,
                                  const data::Episode& episode, int dim,
                                  int maxLength) {
  VLN_CHECK_ARG(static_cast<bool>(source),
                "instructionFeatures(): model.instruction_features is "
                "rxr_text but no text feature source was given (episode ",
                episode.episode_id, ")");
  VLN_CHECK_ARG(maxLength >= 1,
                "instructionFeatures(): maxLength must be >= 1");
  const torch::Tensor features = source(episode);
  VLN_CHECK_ARG(
      features.defined() && features.dim() == 2 && features.size(0) >= 1 &&
          features.size(1) == dim && features.is_floating_point(),
      "instructionFeatures(): episode ", episode.episode_id,
      ": expected text features [L, ", dim, "] (model.text_feature_dim), got ",
      features.defined() ? features.sizes() : torch::IntArrayRef{});
  return features.slice(0, 0, maxLength)
      .to(torch::kCPU, torch::kFloat32)
      .unsqueeze(0);
}

torch::Tensor batchInstructionFeatures(std::span<const torch::Tensor> rows) {
  VLN_CHECK_ARG(!rows.empty(), "batchInstructionFeatures(): no rows");
  int64_t longest = 1;
  for (const torch::Tensor& row : rows) {
    VLN_CHECK_ARG(row.dim() == 3 && row.size(0) == 1 &&
                      row.size(2) == rows.front().size(2),
                  "batchInstructionFeatures(): expected rows [1, L, ",
                  rows.front().size(2), "], got ", row.sizes());
    longest = std::max(longest, row.size(1));
  }
  torch::Tensor out = torch::zeros(
      {static_cast<int64_t>(rows.size()), longest, rows.front().size(2)},
      rows.front().options());
  for (size_t k = 0; k < rows.size(); ++k)
    out[static_cast<int64_t>(k)].slice(0, 0, rows[k].size(1)).copy_(rows[k][0]);
  return out;
}

}  // namespace vln::rollout
