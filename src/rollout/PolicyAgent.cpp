#include "rollout/PolicyAgent.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "common/Check.h"
#include "common/Random.h"
#include "rollout/ObservationBatch.h"
#include "rollout/RecurrentState.h"

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

int chooseRow(const torch::Tensor& logits, int64_t row, bool sample,
              std::mt19937_64& rng) {
  const double* values = logits.data_ptr<double>() + row * logits.size(1);
  return chooseAction(
      std::span<const double>(values, static_cast<size_t>(logits.size(1))),
      sample, rng);
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

PolicyAgent::PolicyAgent(std::shared_ptr<models::PolicyImpl> policy,
                         models::ObservationEncoder encoder, int numEnvs,
                         bool sampleActions, uint64_t seed,
                         int maxInstructionLength)
    : stepper_(policy, numEnvs, maxInstructionLength,
               InstructionBatching::kPerEpisode),
      encoder_(std::move(encoder)),
      sample_(sampleActions),
      seed_(seed),
      draws_(static_cast<size_t>(numEnvs)) {
  VLN_CHECK_ARG(!encoder_.is_empty(), "PolicyAgent: the encoder is null");
  const models::ModelConfig& p = policy->config();
  const models::ModelConfig& e = encoder_->config();
  VLN_CHECK_ARG(p.usesRgb() == e.usesRgb() && p.usesDepth() == e.usesDepth(),
                "PolicyAgent: the encoder's modalities (rgb ", e.usesRgb(),
                ", depth ", e.usesDepth(), ") differ from the policy's (rgb ",
                p.usesRgb(), ", depth ", p.usesDepth(), ")");
  policy->eval();
  encoder_->eval();
}

PolicyAgent::~PolicyAgent() = default;

void PolicyAgent::reset(int env, const data::Episode& episode) {
  stateAt(draws_, env, "PolicyAgent", "reset").restart(seed_, episode);
  stepper_.start(env, episode);
}

std::vector<sim::Action> PolicyAgent::act(VectorEnv& envs,
                                          std::span<const int> active) {
  if (active.empty()) return {};
  checkStarted(draws_, active, "PolicyAgent");
  torch::NoGradGuard noGrad;

  // observations -> feature maps on the policy's device -> one step
  const torch::Device device = stepper_.device();
  const ObservationBatch obs =
      batchObservations(envs, active, stepper_.policy().config());
  const models::VisualFeatures features = encoder_->forward(
      obs.rgb.defined() ? obs.rgb.to(device) : obs.rgb,
      obs.depth.defined() ? obs.depth.to(device) : obs.depth);
  const torch::Tensor logits = stepper_.step(active, features)
                                   .to(torch::kCPU, torch::kFloat64)
                                   .contiguous();
  lastProbabilities_ = torch::softmax(logits, /*dim=*/-1).to(torch::kFloat32);

  // argmax (first maximum) or a draw from the episode's own generator;
  // codes 4 and 5 (model.num_actions 6) are LOOK_UP and LOOK_DOWN
  const int numActions = stepper_.policy().config().num_actions;
  std::vector<sim::Action> actions;
  for (size_t k = 0; k < active.size(); ++k) {
    const int chosen = chooseRow(
        logits, static_cast<int64_t>(k), sample_,
        draws_[static_cast<size_t>(active[k])].rng);
    stepper_.took(active[k], chosen);
    actions.push_back(sim::actionFromInt(chosen, numActions));
  }
  return actions;
}

}  // namespace vln::rollout
