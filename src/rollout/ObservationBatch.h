#pragma once
// Turns the environments' observations and instructions into the tensors
// the encoders and policies read.

#include <ATen/core/Tensor.h>

#include <span>
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

}  // namespace vln::rollout
