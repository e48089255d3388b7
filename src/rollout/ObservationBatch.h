#pragma once
// Turns the environments' observations and instructions into the tensors
// the encoders and policies read.

#include <ATen/core/Tensor.h>

#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "data/Episode.h"
#include "models/ModelConfig.h"
#include "rollout/VectorEnv.h"

namespace vln::rollout {

/// Observations of a batch of environments, channels last as rendered.
struct ObservationBatch {
  at::Tensor rgb;  ///< uint8 [N, H, W, 3]; undefined when model.no_rgb
  at::Tensor
      depth;  ///< float [N, H, W, 1] in [0, 1]; undefined when model.no_depth
};

/// Stacks the current observations of `envs` (CPU tensors; the caller moves
/// them to the model's device). Throws std::invalid_argument when an
/// observation's size differs from the model's image size.
ObservationBatch batchObservations(const VectorEnv& envs,
                                   std::span<const int> active,
                                   const models::ModelConfig& model);

/// Instruction tokens int64 [N, L] (PAD 0 on the right), L = the longest
/// unpadded instruction in the batch, capped at `maxLength` (at least 1).
at::Tensor batchInstructions(std::span<const data::Episode* const> episodes,
                                int maxLength);

/// The rule clause of each instruction token of `episodes` (its index in
/// data::ruleClauses() of instruction_text; model.clause_tracker's
/// clause_of_token), int64 [N, width], -1 past the last clause.
at::Tensor batchRuleClauses(std::span<const data::Episode* const> episodes,
                            int64_t width);

/// The label groups world::goalLabels() finds in each of `episodes`'
/// instruction_text (model.goal_match's goal_labels), float
/// [N, world::viewLabelSize()].
at::Tensor batchGoalLabels(std::span<const data::Episode* const> episodes);

/// The text features of an episode's instruction, float [L, D] on the CPU
/// holding its real rows (trailing zero rows may remain; they are padding):
/// what a policy with model.instruction_features: rxr_text reads.
using InstructionFeatureSource =
    std::function<at::Tensor(const data::Episode&)>;

/// A source reading RxR's text feature files of `split` under
/// `featuresDir` (data::loadRxrTextFeatures() by the episode's
/// instruction_id and language) and keeping the file's rows
/// ([valid_tokens, dim], at most RxR's 512 rows; a file of another width
/// is the loader's error). The source throws std::invalid_argument
/// naming the episode when it has no instruction_id, and the loader's
/// errors for bad files.
InstructionFeatureSource rxrTextFeatureSource(
    const std::filesystem::path& featuresDir, const std::string& split,
    int dim);

/// Checks that every episode of `episodes` (of split `split`) has its text
/// feature file under `featuresDir`, before a run spends time on them.
/// Throws std::runtime_error naming the first missing file, its episode and
/// how many are missing; std::invalid_argument for an episode without
/// instruction_id.
void requireRxrTextFeatureFiles(const std::filesystem::path& featuresDir,
                                const std::string& split,
                                std::span<const data::Episode* const> episodes);

/// One episode's text features from `source`, checked ([L, dim] float with
/// L >= 1, else std::invalid_argument naming the episode) and cut to its
/// first `maxLength` rows: [1, L', dim].
at::Tensor instructionFeatures(const InstructionFeatureSource& source,
                               const data::Episode& episode, int dim,
                               int maxLength);

/// Rows of instructionFeatures() ([1, L_i, D] each) stacked into
/// [N, max L_i, D], zero rows after each (padding for the encoder).
at::Tensor batchInstructionFeatures(std::span<const at::Tensor> rows);

}  // namespace vln::rollout
