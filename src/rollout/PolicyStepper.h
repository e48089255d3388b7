#pragma once
// Steps a recurrent VLN policy for a batch of environments, keeping each
// environment's recurrent state and encoded instruction between steps:
// the policy side of the policy agent (PolicyAgent.h) and of DAgger
// collection (train/Collector.h), which also feeds it the observations'
// features and the actions actually taken.
//
// How instructions are batched trades speed against independence from the
// batch (float sums round differently for other batch shapes):
//  - kPerEpisode: each instruction is encoded alone when its episode starts
//    and the rows are stacked at each step (the encoder packs sequences and
//    attention masks padding, so an episode's actions do not depend on
//    which episodes share its batch): evaluation;
//  - kJoint: the running episodes' instructions are encoded together
//    whenever that set changes: DAgger collection's default;
//  - kOneByOne: per-episode encodings and one policy step per environment,
//    so every number is independent of the batch (trainer.exact_resume).

#include <ATen/core/Tensor.h>

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "data/Episode.h"
#include "models/ObservationEncoder.h"
#include "models/Policy.h"
#include "rollout/ObservationBatch.h"
#include "rollout/RecurrentState.h"

namespace vln::rollout {

enum class InstructionBatching { kPerEpisode, kJoint, kOneByOne };

class PolicyStepper {
 public:
  /// `policy` runs under NoGradGuard on the device of its parameters (the
  /// caller sets eval or train mode); `numEnvs` bounds the environment
  /// indices; `maxInstructionLength` caps the tokens (or text feature
  /// rows) fed to the encoder (dataset.max_instruction_length).
  PolicyStepper(std::shared_ptr<models::PolicyImpl> policy, int numEnvs,
                int maxInstructionLength, InstructionBatching batching);
  ~PolicyStepper();

  /// Where a policy with model.instruction_features: rxr_text gets each
  /// episode's text features (read once per episode, at start()); without
  /// one, start() throws std::invalid_argument for such a policy.
  void setInstructionFeatures(InstructionFeatureSource source) {
    featureSource_ = std::move(source);
  }

  /// Environment `env` starts `episode` (which must outlive its use): zero
  /// state, no previous action.
  void start(int env, const data::Episode& episode);
  /// One policy step of `envs` (each started) from their visual features
  /// (rows in the order of `envs`, on the policy's device): logits
  /// [envs.size(), model.num_actions] on that device. Each environment's hidden
  /// state advances; its previous action stays until took().
  at::Tensor step(std::span<const int> envs,
                  const models::VisualFeatures& features);
  /// The action environment `env` took after its last step: its previous
  /// action at the next one.
  void took(int env, int64_t action);

  /// Keep each step's attention over the instruction (CMA only) for
  /// instructionAttention(); off by default (a copy to the CPU per step).
  void keepInstructionAttention(bool keep) { keepAttention_ = keep; }
  /// The attention of environment `env`'s last step over its instruction's
  /// tokens (weights summing to 1, one per token fed to the encoder);
  /// empty when not kept, before the first step, or for policies without
  /// instruction attention.
  const std::vector<float>& instructionAttention(int env) const;

  const models::PolicyImpl& policy() const { return *policy_; }
  c10::Device device() const { return device_; }

 private:
  struct EnvState;
  at::Tensor stepTogether(std::span<const int> envs,
                          const models::VisualFeatures& features);
  // the encoder's input for `states`: tokens [N, L] or text features
  // [N, L, D], on the policy's device
  at::Tensor instructionInput(std::span<EnvState* const> states) const;

  std::shared_ptr<models::PolicyImpl> policy_;
  int maxInstructionLength_;
  InstructionBatching batching_;
  InstructionFeatureSource featureSource_;
  c10::Device device_;
  bool keepAttention_ = false;
  std::vector<std::unique_ptr<EnvState>> states_;
  // kJoint: the encoding of the episodes it was made for
  models::EncodedInstruction joint_;
  std::vector<const data::Episode*> jointFor_;
};

}  // namespace vln::rollout
