#include "rollout/PolicyAgent.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "common/Check.h"
#include "common/Random.h"
#include "eval/Baselines.h"
#include "rollout/ObservationBatch.h"
#include "rollout/RecurrentAgentState.h"

namespace vln::rollout {

// ---------------------------------------------------------------------------
// helpers

int sampleIndex(std::span<const double> probabilities, std::mt19937_64& rng) {
  VLN_CHECK_ARG(!probabilities.empty(), "sampleIndex(): no probabilities");
  double sum = 0.0;
  for (double p : probabilities) {
    VLN_CHECK_ARG(p >= 0.0 && std::isfinite(p),
                  "sampleIndex(): probabilities must be finite and >= 0, got ",
                  p);
    sum += p;
  }
  VLN_CHECK_ARG(sum > 0.0, "sampleIndex(): probabilities sum to 0");
  // inverse CDF on the unnormalised masses; the last index with mass
  // absorbs rounding so a draw close to 1 never falls off the end
  const double u = common::uniform01(rng) * sum;
  int last = static_cast<int>(probabilities.size()) - 1;
  while (last > 0 && probabilities[static_cast<size_t>(last)] == 0.0) --last;
  double cumulative = 0.0;
  for (int i = 0; i < last; ++i) {
    cumulative += probabilities[static_cast<size_t>(i)];
    if (probabilities[static_cast<size_t>(i)] > 0.0 && u < cumulative) return i;
  }
  return last;
}

int chooseAction(std::span<const double> logits, bool sample,
                 std::mt19937_64& rng) {
  VLN_CHECK_ARG(!logits.empty(), "chooseAction(): no logits");
  int best = 0;
  for (size_t a = 1; a < logits.size(); ++a)
    if (logits[a] > logits[static_cast<size_t>(best)])
      best = static_cast<int>(a);
  if (!sample) return best;
  // softmax shifted by the maximum (no overflow)
  std::vector<double> probabilities(logits.size());
  for (size_t a = 0; a < logits.size(); ++a)
    probabilities[a] = std::exp(logits[a] - logits[static_cast<size_t>(best)]);
  return sampleIndex(probabilities, rng);
}

models::EncodedInstruction stackInstructions(
    std::span<const models::EncodedInstruction* const> rows) {
  VLN_CHECK_ARG(!rows.empty(), "stackInstructions(): no rows");
  if (rows.size() == 1) return *rows.front();
  const models::EncodedInstruction& first = *rows.front();
  for (const auto* row : rows)
    VLN_CHECK_ARG(row->states.defined() == first.states.defined() &&
                      row->keys.defined() == first.keys.defined() &&
                      row->mask.defined() == first.mask.defined() &&
                      row->summary.defined() == first.summary.defined(),
                  "stackInstructions(): rows encoded by different policies");

  // per-token tensors [1, L_i, ...] padded to the longest row
  int64_t longest = 0;
  for (const auto* row : rows)
    if (row->mask.defined()) longest = std::max(longest, row->mask.size(1));
  const auto batch = static_cast<int64_t>(rows.size());
  auto padTokens = [&](torch::Tensor models::EncodedInstruction::*member) {
    const torch::Tensor& like = first.*member;
    std::vector<int64_t> shape = like.sizes().vec();
    shape[0] = batch;
    shape[1] = longest;
    torch::Tensor out = torch::zeros(shape, like.options());
    for (int64_t b = 0; b < batch; ++b) {
      const torch::Tensor& row = rows[static_cast<size_t>(b)]->*member;
      VLN_CHECK_ARG(row.size(0) == 1, "stackInstructions(): expected one ",
                    "episode per row, got ", row.sizes());
      out[b].slice(0, 0, row.size(1)).copy_(row[0]);
    }
    return out;
  };
  models::EncodedInstruction out;
  if (first.states.defined())
    out.states = padTokens(&models::EncodedInstruction::states);
  if (first.keys.defined())
    out.keys = padTokens(&models::EncodedInstruction::keys);
  if (first.mask.defined())
    out.mask = padTokens(&models::EncodedInstruction::mask);
  if (first.summary.defined()) {
    std::vector<torch::Tensor> summaries;
    for (const auto* row : rows) summaries.push_back(row->summary);
    out.summary = torch::cat(summaries, /*dim=*/0);
  }
  return out;
}

// ---------------------------------------------------------------------------
// PolicyAgent

struct PolicyAgent::EnvState : RecurrentEnvState {
  models::EncodedInstruction instruction;  // one row, [1, L, ...]
};

namespace {

// the device of the policy's parameters (config.device when it has none)
torch::Device policyDevice(const models::PolicyImpl& policy) {
  const auto parameters = policy.parameters();
  if (!parameters.empty()) return parameters.front().device();
  return models::modelDevice(policy.config());
}

}  // namespace

PolicyAgent::PolicyAgent(std::shared_ptr<models::PolicyImpl> policy,
                         models::ObservationEncoder encoder, int numEnvs,
                         bool sampleActions, uint64_t seed,
                         int maxInstructionLength)
    : policy_(std::move(policy)),
      encoder_(std::move(encoder)),
      sample_(sampleActions),
      seed_(seed),
      maxInstructionLength_(maxInstructionLength),
      device_(torch::kCPU) {
  VLN_CHECK_ARG(policy_ != nullptr, "PolicyAgent: the policy is null");
  VLN_CHECK_ARG(!encoder_.is_empty(), "PolicyAgent: the encoder is null");
  VLN_CHECK_ARG(numEnvs >= 1, "PolicyAgent: numEnvs must be >= 1, got ",
                numEnvs);
  VLN_CHECK_ARG(maxInstructionLength >= 1,
                "PolicyAgent: dataset.max_instruction_length must be >= 1, "
                "got ",
                maxInstructionLength);
  const models::ModelConfig& p = policy_->config();
  const models::ModelConfig& e = encoder_->config();
  VLN_CHECK_ARG(p.usesRgb() == e.usesRgb() && p.usesDepth() == e.usesDepth(),
                "PolicyAgent: the encoder's modalities (rgb ", e.usesRgb(),
                ", depth ", e.usesDepth(), ") differ from the policy's (rgb ",
                p.usesRgb(), ", depth ", p.usesDepth(), ")");
  device_ = policyDevice(*policy_);
  policy_->eval();
  encoder_->eval();
  for (int i = 0; i < numEnvs; ++i)
    states_.push_back(std::make_unique<EnvState>());
}

PolicyAgent::~PolicyAgent() = default;

void PolicyAgent::reset(int env, const data::Episode& episode) {
  EnvState& s = stateAt(states_, env, "PolicyAgent", "reset");
  torch::NoGradGuard noGrad;
  // the instruction is encoded alone, so its encoding never depends on
  // which episodes share the batch
  s.instruction = {};
  if (policy_->config().usesInstruction()) {
    const data::Episode* one[] = {&episode};
    s.instruction = policy_->encodeInstruction(
        batchInstructions(one, maxInstructionLength_).to(device_));
  }
  s.restart(policy_->initialHidden(1)[0], seed_, episode);
}

std::vector<sim::Action> PolicyAgent::act(VectorEnv& envs,
                                          std::span<const int> active) {
  const auto n = static_cast<int64_t>(active.size());
  if (n == 0) return {};
  const std::vector<EnvState*> states =
      activeStates(states_, active, "PolicyAgent");
  torch::NoGradGuard noGrad;

  // observations -> feature maps on the policy's device
  const models::ModelConfig& model = policy_->config();
  const ObservationBatch obs = batchObservations(envs, active, model);
  const models::VisualFeatures features = encoder_->forward(
      obs.rgb.defined() ? obs.rgb.to(device_) : obs.rgb,
      obs.depth.defined() ? obs.depth.to(device_) : obs.depth);

  // per-environment state gathered into one batch
  models::EncodedInstruction instruction;
  if (model.usesInstruction()) {
    std::vector<const models::EncodedInstruction*> rows;
    for (const EnvState* s : states) rows.push_back(&s->instruction);
    instruction = stackInstructions(rows);
  }
  const RecurrentInputs recurrent = recurrentInputs(states, device_);
  models::PolicyInputs inputs;
  inputs.rgb = features.rgb;
  inputs.depth = features.depth;
  inputs.prev_actions = recurrent.prevActions;
  inputs.not_done = recurrent.notDone;
  const models::PolicyOutputs out =
      policy_->step(instruction, inputs, recurrent.hidden);

  // argmax (first maximum) or a draw from the episode's own generator
  const torch::Tensor logits =
      out.logits.to(torch::kCPU, torch::kFloat64).contiguous();
  lastProbabilities_ = torch::softmax(logits, /*dim=*/-1).to(torch::kFloat32);
  return chooseAndAdvance(logits, out.hidden, states, sample_);
}

}  // namespace vln::rollout
