#pragma once
// A trained policy as an evaluation Agent: encodes the batch's observations,
// runs one policy step per act() (recurrent state and encoded instruction
// kept per environment) and picks argmax or sampled actions.
//
// Batching does not change behaviour: each episode's instruction is encoded
// on its own at reset() (PolicyStepper's kPerEpisode), recurrent state and
// previous action are per environment, and sampling draws from a
// per-episode generator seeded by (seed, episode id)
// (common::episodeSeed()), so the actions of an episode are the same
// whichever episodes share its batch and whatever the thread count.

#include <ATen/core/Tensor.h>

#include <memory>
#include <random>
#include <span>
#include <vector>

#include "models/ObservationEncoder.h"
#include "models/Policy.h"
#include "rollout/Agent.h"
#include "rollout/PolicyStepper.h"
#include "rollout/RecurrentState.h"

namespace vln::rollout {

class PolicyAgent : public Agent {
 public:
  /// `policy` and `encoder` are used in eval mode under NoGradGuard on the
  /// policy's device. `numEnvs` bounds the environment indices.
  /// `maxInstructionLength` caps the instruction tokens fed to the encoder
  /// (dataset.max_instruction_length).
  PolicyAgent(std::shared_ptr<models::PolicyImpl> policy,
              models::ObservationEncoder encoder, int numEnvs,
              bool sampleActions, uint64_t seed, int maxInstructionLength);
  ~PolicyAgent() override;
  void reset(int env, const data::Episode& episode) override;
  std::vector<sim::Action> act(VectorEnv& envs, std::span<const int> active) override;
  void keepInstructionAttention(bool keep) override {
    stepper_.keepInstructionAttention(keep);
  }
  std::vector<float> instructionAttention(int env) const override {
    return stepper_.instructionAttention(env);
  }

  /// Where an rxr_text policy reads each episode's instruction features
  /// (PolicyStepper::setInstructionFeatures()); call before reset().
  void setInstructionFeatures(InstructionFeatureSource source) {
    stepper_.setInstructionFeatures(std::move(source));
  }

  /// Action probabilities of the last act() call, float [active,
  /// model.num_actions] on the CPU (softmax of the logits), for tests and
  /// diagnostics.
  const at::Tensor& lastProbabilities() const { return lastProbabilities_; }

 private:
  PolicyStepper stepper_;
  models::ObservationEncoder encoder_;
  bool sample_;
  uint64_t seed_;
  std::vector<EpisodeDraws> draws_;
  at::Tensor lastProbabilities_;
};

/// Draws an action index from `probabilities` (non-negative, any sum > 0) by
/// inverse CDF with one common::uniform01() draw of `rng`, in double precision,
/// so a given generator state always picks the same action (portable, unlike
/// std::discrete_distribution).
int sampleIndex(std::span<const double> probabilities, std::mt19937_64& rng);

/// The action of one row of logits: the first maximum, or (when `sample`) a
/// sampleIndex() draw from their softmax computed in double precision.
/// Shared by PolicyAgent and ScriptedPolicyAgent so both choose alike.
int chooseAction(std::span<const double> logits, bool sample,
                 std::mt19937_64& rng);

/// chooseAction() on row `row` of `logits` (float64 [n, actions] on the
/// CPU, contiguous).
int chooseRow(const at::Tensor& logits, int64_t row, bool sample,
              std::mt19937_64& rng);

/// Rows of one-episode encoded instructions ([1, L_i, ...] each) stacked
/// into a batch [B, max L_i, ...]: states and keys padded with zeros, the
/// mask with false (policies attend only where the mask is true), summaries
/// stacked as they are.
models::EncodedInstruction stackInstructions(
    std::span<const models::EncodedInstruction* const> rows);

}  // namespace vln::rollout
