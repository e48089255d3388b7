#pragma once
// A trained policy as an evaluation Agent: encodes the batch's observations,
// runs one policy step per act() (recurrent state and encoded instruction
// kept per environment) and picks argmax or sampled actions.

#include <torch/torch.h>

#include <memory>
#include <random>
#include <vector>

#include "eval/Agent.h"
#include "models/ObservationEncoder.h"
#include "models/Policy.h"

namespace vln::eval {

class PolicyAgent : public Agent {
 public:
  /// `policy` and `encoder` are used in eval mode under NoGradGuard on the
  /// policy's device. `numEnvs` bounds the environment indices.
  PolicyAgent(std::shared_ptr<models::PolicyImpl> policy,
              models::ObservationEncoder encoder, int numEnvs,
              bool sampleActions, uint64_t seed, int maxInstructionLength);
  void reset(int env, const data::Episode& episode) override;
  std::vector<sim::Action> act(VectorEnv& envs, std::span<const int> active) override;

 private:
  struct EnvState;
  std::shared_ptr<models::PolicyImpl> policy_;
  models::ObservationEncoder encoder_;
  bool sample_;
  std::mt19937_64 rng_;
  int maxInstructionLength_;
  std::vector<std::unique_ptr<EnvState>> states_;
};

}  // namespace vln::eval
