#pragma once
// Tiny random policies for the evaluation tests (32x32 images, small CNNs,
// the test house's 23-token vocabulary). The STOP logit is lowered so that
// episodes run to the step limit (a change in behaviour cannot hide behind
// "every policy stops at once"), and the action head can be scaled to make
// sampled actions follow the logits closely (argmax does not depend on it).

#include <torch/torch.h>

#include <memory>

#include "models/ModelConfig.h"
#include "models/ModelTestUtil.h"
#include "models/ObservationEncoder.h"
#include "models/Policy.h"
#include "rollout/RolloutTestWorld.h"

namespace vln::rollout::test {

/// The model tests' tiny model (models/ModelTestUtil.h) over the test
/// house's vocabulary.
inline models::ModelConfig tinyModel(models::PolicyType type) {
  models::ModelConfig c = models::test::tinyConfig(type);
  c.vocab_size = kTestVocab;
  return c;
}

struct TinyAgentModel {
  std::shared_ptr<models::PolicyImpl> policy;
  models::ObservationEncoder encoder{nullptr};
};

/// A seeded random policy and encoder; action-head weights x `gain`, STOP
/// bias lowered by `stopPenalty`.
inline TinyAgentModel tinyAgentModel(models::PolicyType type, uint64_t seed,
                                     double gain = 400.0,
                                     double stopPenalty = 3.0) {
  torch::manual_seed(seed);
  TinyAgentModel m;
  const models::ModelConfig config = tinyModel(type);
  m.policy = models::makePolicy(config);
  m.encoder = models::ObservationEncoder(config);
  torch::NoGradGuard noGrad;
  for (auto& p : m.policy->named_parameters()) {
    if (p.key() == "action_head.weight") p.value().mul_(gain);
    if (p.key() == "action_head.bias") p.value()[0].sub_(stopPenalty);
  }
  return m;
}

}  // namespace vln::rollout::test
