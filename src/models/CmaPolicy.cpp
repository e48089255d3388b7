#include "models/CmaPolicy.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/Check.h"

namespace vln::models {

CmaPolicyImpl::CmaPolicyImpl(const ModelConfig& config)
    : PolicyImpl(config),
      scale_(1.0 / std::sqrt(static_cast<double>(config.hidden_size / 2))) {
  VLN_CHECK_ARG(config.policy == PolicyType::kCma,
                "CmaPolicy: model.policy must be cma, got ",
                policyName(config.policy));
  namespace nn = torch::nn;
  const int64_t hidden = config_.hidden_size;
  const int64_t half = hidden / 2;
  const int64_t posDim = config_.spatial_embedding_dim;
  const int64_t prevDim = config_.prev_action_embedding_dim;

  // widths of GRU1's input and of the second GRU's compressed input grow
  // with each modality the model keeps
  int64_t gru1In = prevDim;
  int64_t compressIn = hidden + prevDim;
  if (config_.countsTurns()) {
    turn_count_embedding = register_module(
        "turn_count_embedding",
        nn::Embedding(2 * kMaxTurnCount + 1, config_.turn_count_embedding_dim));
    gru1In += config_.turn_count_embedding_dim;
    compressIn += config_.turn_count_embedding_dim;
  }
  if (config_.usesRgb()) {
    const int64_t channels = rgbShape_[0];
    const int64_t positions = rgbShape_[1] * rgbShape_[2];
    rgb_spatial_embedding = register_module("rgb_spatial_embedding",
                                            nn::Embedding(positions, posDim));
    rgb_linear = register_module(
        "rgb_linear",
        nn::Linear(channels + posDim, config_.rgb_projection_size));
    rgb_kv = register_module(
        "rgb_kv",
        nn::Linear(channels + posDim, half + config_.rgb_projection_size));
    gru1In += config_.rgb_projection_size;
    compressIn += config_.rgb_projection_size;
  }
  if (config_.usesDepth()) {
    const int64_t channels = depthShape_[0];
    const int64_t positions = depthShape_[1] * depthShape_[2];
    depth_spatial_embedding = register_module("depth_spatial_embedding",
                                              nn::Embedding(positions, posDim));
    depth_linear = register_module("depth_linear",
                                   nn::Linear((channels + posDim) * positions,
                                              config_.depth_projection_size));
    depth_kv = register_module(
        "depth_kv",
        nn::Linear(channels + posDim, half + config_.depth_projection_size));
    gru1In += config_.depth_projection_size;
    compressIn += config_.depth_projection_size;
  }
  prev_action_embedding = register_module(
      "prev_action_embedding", nn::Embedding(config_.num_actions + 1, prevDim));
  state_encoder = register_module("state_encoder", MaskedGru(gru1In, hidden));

  if (config_.usesInstruction()) {
    const int64_t textDim = config_.instructionStateSize();
    state_q = register_module("state_q", nn::Linear(hidden, half));
    text_k = register_module("text_k", nn::Linear(textDim, half));
    text_q = register_module("text_q", nn::Linear(textDim, half));
    compressIn += textDim;
  } else if (config_.usesRgb() || config_.usesDepth()) {
    // without text the visual query is a learned constant, which is what
    // VLN-CE's zeroed instruction reduces to (text_q's bias)
    const double bound =
        1.0 / std::sqrt(static_cast<double>(config_.instructionStateSize()));
    visual_query = register_parameter(
        "visual_query", torch::empty({half}).uniform_(-bound, bound));
  }
  second_state_compress =
      register_module("second_state_compress", nn::Linear(compressIn, hidden));
  second_state_encoder =
      register_module("second_state_encoder", MaskedGru(hidden, hidden));
  action_head =
      register_module("action_head", nn::Linear(hidden, config_.num_actions));
  if (config_.progress_monitor)
    progress_monitor =
        register_module("progress_monitor", nn::Linear(hidden, 1));
  initHeads(action_head, &progress_monitor);
}

EncodedInstruction CmaPolicyImpl::prepareInstruction(
    const InstructionStates& states) {
  EncodedInstruction out;
  out.states = states.states;
  out.mask = states.mask;
  out.keys = text_k(states.states);  // once per episode, not per step
  return out;
}

torch::Tensor CmaPolicyImpl::attendVisual(const torch::Tensor& q,
                                          const torch::Tensor& feats,
                                          const torch::Tensor& pos,
                                          torch::nn::Linear& kv) const {
  const int64_t half = q.size(1);
  const int64_t channels = feats.size(1);
  const torch::Tensor wk = kv->weight.slice(0, 0, half);
  const torch::Tensor bk = kv->bias.slice(0, 0, half);
  const torch::Tensor wv = kv->weight.slice(0, half);
  const torch::Tensor bv = kv->bias.slice(0, half);

  // scores (W_k x_i + b_k) . q = x_i . (W_k^T q) + b_k . q, with x_i the
  // feature column i stacked on position column i
  const torch::Tensor qk = q.matmul(wk);  // [N, C + E]
  const torch::Tensor scores =
      torch::bmm(qk.slice(1, 0, channels).unsqueeze(1), feats).squeeze(1) +
      qk.slice(1, channels).matmul(pos) + q.matmul(bk).unsqueeze(1);
  const torch::Tensor alpha = torch::softmax(scores * scale_, /*dim=*/1);

  // sum_i a_i (W_v x_i + b_v) = W_v (sum_i a_i x_i) + b_v since sum a_i = 1
  const torch::Tensor attendedFeats =
      torch::bmm(feats, alpha.unsqueeze(2)).squeeze(2);     // [N, C]
  const torch::Tensor attendedPos = alpha.matmul(pos.t());  // [N, E]
  return torch::linear(attendedFeats, wv.slice(1, 0, channels), bv) +
         attendedPos.matmul(wv.slice(1, channels).t());
}

PolicyOutputs CmaPolicyImpl::forwardSequence(
    const EncodedInstruction& instruction, const PolicyInputs& inputs,
    const torch::Tensor& hidden) {
  const auto [steps, batch] = checkInputs(inputs, hidden);
  const int64_t n = steps * batch;
  const int64_t posDim = config_.spatial_embedding_dim;
  const torch::Tensor prev = prev_action_embedding(prevActionIndex(inputs));

  // projections of every step at once; the position-embedding part of each
  // linear map is the same for all steps and folds into its bias
  std::vector<torch::Tensor> gru1Parts;
  torch::Tensor rgbFeats, rgbPos, depthFeats, depthPos, rgbIn, depthIn;
  if (config_.usesRgb()) {
    const int64_t channels = rgbShape_[0];
    const int64_t positions = rgbShape_[1] * rgbShape_[2];
    rgbFeats = trainingDropout(inputs.rgb.reshape({n, channels, positions}));
    rgbPos = rgb_spatial_embedding->weight.view({posDim, positions});
    const torch::Tensor& w = rgb_linear->weight;
    const torch::Tensor bias =
        rgb_linear->bias + w.slice(1, channels).mv(rgbPos.mean(1));
    rgbIn = torch::relu(
        torch::linear(rgbFeats.mean(2), w.slice(1, 0, channels), bias));
    gru1Parts.push_back(rgbIn.view({steps, batch, -1}));
  }
  if (config_.usesDepth()) {
    const int64_t channels = depthShape_[0];
    const int64_t positions = depthShape_[1] * depthShape_[2];
    depthFeats =
        trainingDropout(inputs.depth.reshape({n, channels, positions}));
    depthPos = depth_spatial_embedding->weight.view({posDim, positions});
    const torch::Tensor& w = depth_linear->weight;
    const int64_t split = channels * positions;
    const torch::Tensor bias =
        depth_linear->bias + w.slice(1, split).mv(depthPos.flatten());
    depthIn = torch::relu(torch::linear(depthFeats.reshape({n, split}),
                                        w.slice(1, 0, split), bias));
    gru1Parts.push_back(depthIn.view({steps, batch, -1}));
  }
  gru1Parts.push_back(prev);
  torch::Tensor counts, turns;
  if (turn_count_embedding) {
    counts = turnCounts(inputs.prev_actions, inputs.not_done,
                        hidden.select(1, 2).select(1, 0));
    turns = turn_count_embedding(
        (counts + static_cast<double>(kMaxTurnCount)).to(torch::kInt64));
    gru1Parts.push_back(turns);
  }
  auto [state, lastState] = state_encoder(torch::cat(gru1Parts, /*dim=*/-1),
                                          hidden.select(1, 0), inputs.not_done);

  // attention over the instruction, queried by every GRU1 state at once
  std::vector<torch::Tensor> compressParts{state};
  torch::Tensor visualQuery, textAttention;
  if (config_.usesInstruction()) {
    TORCH_CHECK(instruction.states.defined() && instruction.keys.defined() &&
                    instruction.mask.defined() &&
                    instruction.states.size(0) == batch,
                "CmaPolicy::forwardSequence(): expected an encoded "
                "instruction of batch ",
                batch, "; call encodeInstruction() first");
    const torch::Tensor q = state_q(state).transpose(0, 1);  // [B, T, K]
    const torch::Tensor scores =
        torch::bmm(q, instruction.keys.transpose(1, 2)) * scale_;  // [B,T,L]
    const torch::Tensor alpha = torch::softmax(
        scores.masked_fill(instruction.mask.logical_not().unsqueeze(1),
                           -std::numeric_limits<float>::infinity()),
        /*dim=*/-1);
    const torch::Tensor text =
        torch::bmm(alpha, instruction.states).transpose(0, 1);  // [T, B, D]
    compressParts.push_back(text);
    visualQuery = text_q(text).reshape({n, -1});
    textAttention = alpha.transpose(0, 1);  // [T, B, L]
  } else if (config_.usesRgb() || config_.usesDepth()) {
    visualQuery = visual_query.unsqueeze(0).expand({n, visual_query.size(0)});
  }
  if (config_.usesRgb())
    compressParts.push_back(attendVisual(visualQuery, rgbFeats, rgbPos, rgb_kv)
                                .view({steps, batch, -1}));
  if (config_.usesDepth())
    compressParts.push_back(
        attendVisual(visualQuery, depthFeats, depthPos, depth_kv)
            .view({steps, batch, -1}));
  compressParts.push_back(prev);
  if (turns.defined()) compressParts.push_back(turns);

  const torch::Tensor x =
      torch::relu(second_state_compress(torch::cat(compressParts, /*dim=*/-1)));
  auto [actionState, lastAction] =
      second_state_encoder(x, hidden.select(1, 1), inputs.not_done);

  PolicyOutputs out;
  out.logits = action_head(trainingDropout(actionState));
  if (progress_monitor)
    out.progress = torch::tanh(progress_monitor(actionState)).squeeze(-1);
  if (counts.defined()) {
    // the last count in column 0 of the state's third row
    const torch::Tensor countRow = torch::cat(
        {counts[steps - 1].unsqueeze(1),
         torch::zeros({batch, config_.hidden_size - 1}, counts.options())},
        /*dim=*/1);
    out.hidden = torch::stack({lastState, lastAction, countRow}, /*dim=*/1);
  } else {
    out.hidden = torch::stack({lastState, lastAction}, /*dim=*/1);
  }
  out.instruction_attention = textAttention;
  return out;
}

torch::Tensor turnCounts(const torch::Tensor& prevActions,
                         const torch::Tensor& notDone,
                         const torch::Tensor& start) {
  // A plain loop on the CPU: T sequential steps of a few numbers each,
  // which as tensor operations would be T x 8 dispatches.
  const torch::Tensor actions =
      prevActions.to(torch::kCPU, torch::kInt64).contiguous();
  const torch::Tensor notDoneCpu =
      notDone.to(torch::kCPU, torch::kFloat32).contiguous();
  const torch::Tensor startCpu =
      start.detach().to(torch::kCPU, torch::kFloat32).contiguous();
  const int64_t steps = actions.size(0);
  const int64_t batch = actions.size(1);
  torch::Tensor counts = torch::empty({steps, batch}, torch::kFloat32);
  const auto a = actions.accessor<int64_t, 2>();
  const auto live = notDoneCpu.accessor<float, 2>();
  const auto first = startCpu.accessor<float, 1>();
  auto out = counts.accessor<float, 2>();
  const auto max = static_cast<float>(kMaxTurnCount);
  for (int64_t b = 0; b < batch; ++b) {
    float count = std::clamp(std::round(first[b]), -max, max);
    for (int64_t t = 0; t < steps; ++t) {
      if (live[t][b] == 0.0f || a[t][b] == kMoveForwardAction) {
        count = 0.0f;
      } else if (a[t][b] == kTurnLeftAction) {
        count = std::min(count + 1.0f, max);
      } else if (a[t][b] == kTurnRightAction) {
        count = std::max(count - 1.0f, -max);
      }
      out[t][b] = count;
    }
  }
  return counts.to(start.options().requires_grad(false));
}

}  // namespace vln::models
