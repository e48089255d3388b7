#pragma once
// Synthetic teacher-forcing batches with the layout and statistics of
// VLN-CE's DAgger batches, for benchmarks and smoke tests that must not
// depend on a dataset: episodes of random length (the longest exactly
// `steps`) padded to `steps`, instructions of random length (the longest
// exactly `instr_len`), non-negative features like pooled post-ReLU CNN
// outputs, expert actions that are mostly MOVE_FORWARD and end in STOP.

#include <ATen/core/Tensor.h>

#include <cstdint>

#include "models/ModelConfig.h"
#include "models/Policy.h"

namespace vln::models {

/// One padded batch, time-major, on the CPU.
struct TeacherForcingBatch {
  at::Tensor tokens;    ///< int64 [B, instr_len], PAD 0 at the end
  PolicyInputs inputs;     ///< [T, B, ...] features, previous actions, masks
  at::Tensor actions;   ///< int64 [T, B] expert actions
  at::Tensor weights;   ///< float [T, B] inflection weights (3.2), 0 pad
  at::Tensor valid;     ///< bool [T, B] real steps
  at::Tensor progress;  ///< float [T, B] (t + 1) / length
};

/// A reproducible batch for `config`'s feature shapes (seeded by `seed`).
/// Requires batch >= 1, steps >= 2, instrLen >= 2.
TeacherForcingBatch syntheticBatch(const ModelConfig& config, int64_t batch,
                                   int64_t steps, int64_t instrLen,
                                   uint64_t seed = 0);

}  // namespace vln::models
