#include "eval/PolicyAgent.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "common/Check.h"
#include "eval/Baselines.h"
#include "eval/ObservationBatch.h"

namespace vln::eval {

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
  const double u = uniformUnit(rng) * sum;
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
    if (logits[a] > logits[static_cast<size_t>(best)]) best = static_cast<int>(a);
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
  if (first.keys.defined()) out.keys = padTokens(&models::EncodedInstruction::keys);
  if (first.mask.defined()) out.mask = padTokens(&models::EncodedInstruction::mask);
  if (first.summary.defined()) {
    std::vector<torch::Tensor> summaries;
    for (const auto* row : rows) summaries.push_back(row->summary);
    out.summary = torch::cat(summaries, /*dim=*/0);
  }
  return out;
}

// ---------------------------------------------------------------------------
// PolicyAgent

struct PolicyAgent::EnvState {
  bool started = false;
  models::EncodedInstruction instruction;  // one row, [1, L, ...]
  torch::Tensor hidden;                    // [layers, hidden_size]
  int64_t prevAction = 0;
  bool first = true;  // not_done = 0 on the episode's first step
  std::mt19937_64 rng;
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
                "got ", maxInstructionLength);
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

PolicyAgent::EnvState& PolicyAgent::stateOf(int env, const char* method) {
  VLN_CHECK_ARG(env >= 0 && env < static_cast<int>(states_.size()),
                "PolicyAgent::", method, "(): environment ", env,
                " out of range [0, ", states_.size(), ")");
  return *states_[static_cast<size_t>(env)];
}

void PolicyAgent::reset(int env, const data::Episode& episode) {
  EnvState& s = stateOf(env, "reset");
  torch::NoGradGuard noGrad;
  // the instruction is encoded alone, so its encoding never depends on
  // which episodes share the batch
  s.instruction = {};
  if (policy_->config().usesInstruction()) {
    const data::Episode* one[] = {&episode};
    s.instruction = policy_->encodeInstruction(
        batchInstructions(one, maxInstructionLength_).to(device_));
  }
  s.hidden = policy_->initialHidden(1)[0];
  s.prevAction = 0;
  s.first = true;
  s.rng.seed(episodeSeed(seed_, std::to_string(episode.episode_id)));
  s.started = true;
}

std::vector<sim::Action> PolicyAgent::act(VectorEnv& envs,
                                          std::span<const int> active) {
  const auto n = static_cast<int64_t>(active.size());
  if (n == 0) return {};
  std::vector<EnvState*> states;
  for (int env : active) {
    EnvState& s = stateOf(env, "act");
    VLN_CHECK_ARG(s.started, "PolicyAgent::act(): environment ", env,
                  " was never reset");
    states.push_back(&s);
  }
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
  std::vector<torch::Tensor> hidden;
  std::vector<int64_t> prev;
  std::vector<float> notDone;
  for (const EnvState* s : states) {
    hidden.push_back(s->hidden);
    prev.push_back(s->prevAction);
    notDone.push_back(s->first ? 0.0f : 1.0f);
  }
  models::PolicyInputs inputs;
  inputs.rgb = features.rgb;
  inputs.depth = features.depth;
  inputs.prev_actions = torch::tensor(prev, torch::kInt64).to(device_);
  inputs.not_done = torch::tensor(notDone, torch::kFloat32).to(device_);
  const models::PolicyOutputs out =
      policy_->step(instruction, inputs, torch::stack(hidden));

  // argmax (first maximum) or a draw from the episode's own generator
  const torch::Tensor logits =
      out.logits.to(torch::kCPU, torch::kFloat64).contiguous();
  lastProbabilities_ = torch::softmax(logits, /*dim=*/-1).to(torch::kFloat32);
  const double* row = logits.data_ptr<double>();
  std::vector<sim::Action> actions(static_cast<size_t>(n));
  for (int64_t k = 0; k < n; ++k) {
    EnvState& s = *states[static_cast<size_t>(k)];
    const int chosen = chooseAction(
        std::span<const double>(row + k * models::kNumActions,
                                static_cast<size_t>(models::kNumActions)),
        sample_, s.rng);
    actions[static_cast<size_t>(k)] = sim::actionFromInt(chosen);
    s.hidden = out.hidden[k];
    s.prevAction = chosen;
    s.first = false;
  }
  return actions;
}

}  // namespace vln::eval
