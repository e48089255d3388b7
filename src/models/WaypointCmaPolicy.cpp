#include "models/WaypointCmaPolicy.h"

#include <cmath>
#include <limits>

#include "common/Check.h"

namespace vln::models {
namespace {

constexpr double kTwoPi = 6.283185307179586;

// the outputs with a steps dimension (all but the hidden state): what step
// mode squeezes and a stepwise sequence joins
constexpr torch::Tensor WaypointPolicyOutputs::*kPerStepOutputs[] = {
    &WaypointPolicyOutputs::logits,
    &WaypointPolicyOutputs::progress,
    &WaypointPolicyOutputs::text_attention,
    &WaypointPolicyOutputs::clause_logits,
    &WaypointPolicyOutputs::clause_before,
    &WaypointPolicyOutputs::clause_pointer,
    &WaypointPolicyOutputs::clause_targets};

// sin, cos of m * heading for m = 1 .. harmonics, stacked on a new last
// dimension ([..] -> [.., 2 * harmonics])
torch::Tensor headingFeatures(const torch::Tensor& heading, int64_t harmonics) {
  std::vector<torch::Tensor> parts;
  for (int64_t m = 1; m <= harmonics; ++m) {
    const torch::Tensor angle = m == 1 ? heading : heading * double(m);
    parts.push_back(torch::sin(angle));
    parts.push_back(torch::cos(angle));
  }
  return torch::stack(parts, -1);
}

// [.., 2] heading, distance -> [.., 2 * harmonics + 1]: the heading's
// features, distance / 3
torch::Tensor polarFeatures(const torch::Tensor& polar, int64_t harmonics) {
  return torch::cat({headingFeatures(polar.select(-1, 0), harmonics),
                     (polar.select(-1, 1) / 3.0).unsqueeze(-1)},
                    -1);
}

// softmax attention of queries q [n, D] over values [n, M, Dv] with keys
// [n, M, D] (mask [n, M] bool, true = attend; may be undefined); the
// weights [n, M] go to `weights` when given
torch::Tensor attend(const torch::Tensor& q, const torch::Tensor& keys,
                     const torch::Tensor& values, const torch::Tensor& mask,
                     torch::Tensor* weights = nullptr) {
  torch::Tensor scores = torch::bmm(keys, q.unsqueeze(2)).squeeze(2) /
                         std::sqrt(static_cast<double>(q.size(1)));
  if (mask.defined())
    scores = scores.masked_fill(mask.logical_not(),
                                -std::numeric_limits<float>::infinity());
  const torch::Tensor alpha = torch::softmax(scores, 1);
  if (weights != nullptr) *weights = alpha;
  return torch::bmm(alpha.unsqueeze(1), values).squeeze(1);
}

// [B, ...] rows of an episode (the instruction's) -> [T * B, ...], the rows
// repeated for each of T steps in the steps' [T, B] order
torch::Tensor repeatOverSteps(const torch::Tensor& t, int64_t steps) {
  std::vector<int64_t> expanded{steps};
  expanded.insert(expanded.end(), t.sizes().begin(), t.sizes().end());
  std::vector<int64_t> flat(t.sizes().begin(), t.sizes().end());
  flat[0] *= steps;
  return t.unsqueeze(0).expand(expanded).reshape(flat);
}

}  // namespace

WaypointCmaPolicyImpl::WaypointCmaPolicyImpl(const ModelConfig& config,
                                             int64_t numViews,
                                             int64_t rgbFeatures,
                                             int64_t depthFeatures)
    : config_(config),
      numViews_(numViews),
      rgbFeatures_(rgbFeatures),
      depthFeatures_(depthFeatures) {
  VLN_CHECK_ARG(numViews >= 1, "WaypointCmaPolicy: numViews must be >= 1, got ",
                numViews);
  VLN_CHECK_ARG(config.usesRgb() || config.usesDepth(),
                "WaypointCmaPolicy: model.no_rgb and model.no_depth leave "
                "nothing to see");
  namespace nn = torch::nn;
  const int64_t hidden = config.hidden_size;
  const int64_t prevDim = config.prev_action_embedding_dim;
  const int64_t polarIn = 2 * config.heading_harmonics + 1;
  int64_t viewIn = polarIn - 1;  // the view's heading
  if (config.goal_match) {
    viewIn += 2 * kGoalGroups;
    goal_stop =
        register_module("goal_stop", nn::Linear(2 * kGoalGroups, hidden));
  } else if (config.usesRgb()) {
    rgb_linear = register_module(
        "rgb_linear", nn::Linear(rgbFeatures, config.rgb_projection_size));
    viewIn += config.rgb_projection_size;
  }
  if (config.usesDepth()) {
    depth_linear = register_module(
        "depth_linear",
        nn::Linear(depthFeatures, config.depth_projection_size));
    viewIn += config.depth_projection_size;
  }
  view_linear = register_module("view_linear", nn::Linear(viewIn, hidden));
  prev_linear =
      register_module("prev_linear", nn::Linear(polarIn + 1, prevDim));
  state_encoder =
      register_module("state_encoder", MaskedGru(hidden + prevDim, hidden));
  int64_t compressIn = hidden + hidden + prevDim;
  if (config.usesInstruction()) {
    instruction_encoder =
        register_module("instruction_encoder", InstructionEncoder(config));
    const int64_t textDim = config.instructionStateSize();
    state_q = register_module("state_q", nn::Linear(hidden, hidden));
    text_k = register_module("text_k", nn::Linear(textDim, hidden));
    text_q = register_module("text_q", nn::Linear(textDim, hidden));
    compressIn += textDim;
    if (config.leg_attention) {
      leg_q = register_module("leg_q", nn::Linear(hidden, hidden));
      compressIn += textDim;
    }
    if (config.candidate_text) {
      candidate_text_q =
          register_module("candidate_text_q", nn::Linear(hidden, hidden));
      candidate_text_linear =
          register_module("candidate_text_linear", nn::Linear(textDim, hidden));
    }
    if (config.clause_tracker) {
      clause_hidden =
          register_module("clause_hidden", nn::Linear(hidden, hidden));
      clause_text = register_module("clause_text", nn::Linear(textDim, hidden));
      clause_advance = register_parameter(
          "clause_advance",
          torch::randn({kClauseAdvances, hidden}) / std::sqrt(double(hidden)));
      clause_score = register_module("clause_score", nn::Linear(hidden, 1));
      if (config.clause_tracker_memory)
        clause_memory =
            register_module("clause_memory", nn::Linear(hidden, hidden));
    }
  } else {
    visual_query = register_parameter(
        "visual_query", torch::randn({hidden}) / std::sqrt(double(hidden)));
  }
  second_state_compress =
      register_module("second_state_compress", nn::Linear(compressIn, hidden));
  second_state_encoder =
      register_module("second_state_encoder", MaskedGru(hidden, hidden));
  candidate_linear =
      register_module("candidate_linear", nn::Linear(hidden + polarIn, hidden));
  stop_key = register_parameter(
      "stop_key", torch::randn({hidden}) / std::sqrt(double(hidden)));
  query_linear =
      register_module("query_linear", nn::Linear(compressIn - prevDim, hidden));
  if (config.progress_monitor)
    progress_monitor =
        register_module("progress_monitor", nn::Linear(hidden, 1));
}

EncodedInstruction WaypointCmaPolicyImpl::encodeInstruction(
    const torch::Tensor& tokens) {
  EncodedInstruction out;
  if (!config_.usesInstruction()) return out;
  const InstructionStates states = instruction_encoder(tokens);
  // padding stays zero: dropout only scales or zeroes values
  out.states = trainingDropout(states.states);
  out.mask = states.mask;
  out.keys = text_k(out.states);
  return out;
}

torch::Tensor WaypointCmaPolicyImpl::trainingDropout(const torch::Tensor& x) {
  return dropoutWhileTraining(x, config_.dropout, is_training());
}

torch::Tensor WaypointCmaPolicyImpl::matchGoal(
    const WaypointPolicyInputs& inputs, int64_t steps, int64_t batch) const {
  const int64_t n = steps * batch;
  VLN_CHECK_ARG(inputs.goal_labels.defined() && inputs.goal_labels.dim() == 2 &&
                    inputs.goal_labels.size(0) == batch &&
                    inputs.goal_labels.size(1) == rgbFeatures_,
                "WaypointCmaPolicy: model.goal_match needs goal_labels [",
                batch, ", ", rgbFeatures_, "], got ",
                inputs.goal_labels.defined() ? inputs.goal_labels.sizes()
                                             : at::IntArrayRef{});
  const torch::Tensor labels = inputs.rgb.reshape({n, numViews_, rgbFeatures_});
  const torch::Tensor groups = repeatOverSteps(
      inputs.goal_labels.to(labels.device(), labels.scalar_type()), steps);
  std::vector<torch::Tensor> matched, named;
  for (int64_t g = 1; g <= kGoalGroups; ++g) {
    const torch::Tensor in = groups.eq(static_cast<double>(g));  // [n, F]
    // probabilities are >= 0, so labels outside the group count as 0
    matched.push_back(
        (labels * in.unsqueeze(1).to(labels.scalar_type())).amax(2));
    named.push_back(
        in.any(1, true).to(labels.scalar_type()).expand({n, numViews_}));
  }
  matched.insert(matched.end(), named.begin(), named.end());
  return torch::stack(matched, 2);  // [n, N, 2G]
}

torch::Tensor WaypointCmaPolicyImpl::encodeViews(
    const WaypointPolicyInputs& inputs, int64_t n, const torch::Tensor& goal) {
  // dropout on the frozen encoders' features reaches the views the state
  // reads and the candidates' keys alike
  std::vector<torch::Tensor> parts;
  if (goal.defined())
    parts.push_back(goal);
  else if (config_.usesRgb())
    parts.push_back(torch::relu(rgb_linear(trainingDropout(
        inputs.rgb.reshape({n, numViews_, rgbFeatures_})))));
  if (config_.usesDepth())
    parts.push_back(torch::relu(depth_linear(trainingDropout(
        inputs.depth.reshape({n, numViews_, depthFeatures_})))));
  const torch::Tensor angles =
      torch::arange(numViews_, parts[0].options()) * (kTwoPi / numViews_);
  const torch::Tensor headings =
      headingFeatures(angles, config_.heading_harmonics);
  parts.push_back(
      headings.unsqueeze(0).expand({n, numViews_, headings.size(1)}));
  return torch::relu(view_linear(torch::cat(parts, 2)));
}

torch::Tensor WaypointCmaPolicyImpl::trackClauses(
    const EncodedInstruction& instruction, const WaypointPolicyInputs& inputs,
    const torch::Tensor& h1, const torch::Tensor& h2Before, int64_t steps,
    int64_t batch, WaypointPolicyOutputs& out) {
  const int64_t L = instruction.mask.size(1);
  const int64_t H = config_.hidden_size;
  VLN_CHECK_ARG(
      inputs.clause_of_token.defined() && inputs.clause_of_token.dim() == 2 &&
          inputs.clause_of_token.size(0) == batch &&
          inputs.clause_of_token.size(1) >= L,
      "WaypointCmaPolicy: model.clause_tracker needs clause_of_token "
      "[",
      batch, ", >= ", L, "], got ",
      inputs.clause_of_token.defined() ? inputs.clause_of_token.sizes()
                                       : at::IntArrayRef{});
  VLN_CHECK_ARG(!inputs.text_mask.defined(),
                "WaypointCmaPolicy: text_mask and model.clause_tracker both "
                "choose the words a decision reads");
  const torch::Device device = h1.device();
  // each token's clause, -1 at padding; a row's clauses, at least one
  const torch::Tensor clauseOf =
      inputs.clause_of_token.slice(1, 0, L)
          .to(device, torch::kLong)
          .masked_fill(instruction.mask.logical_not(), -1);
  const torch::Tensor counts = std::get<0>(clauseOf.max(1)).add(1).clamp_min(1);
  const int64_t C = counts.max().item<int64_t>();
  // r_j: each clause's mean encoded word, [B, C, H]
  const torch::Tensor member =
      clauseOf.unsqueeze(2)
          .eq(torch::arange(C, clauseOf.options()).view({1, 1, C}))
          .to(instruction.states.scalar_type());  // [B, L, C]
  const torch::Tensor sizes = member.sum(1).clamp_min(1.0).unsqueeze(2);
  const torch::Tensor clauses = clause_text(
      torch::bmm(member.transpose(1, 2), instruction.states) / sizes);
  torch::Tensor query = clause_hidden(h1).view({steps, batch, H});
  if (clause_memory) {
    VLN_CHECK_ARG(steps == 1,
                  "WaypointCmaPolicy: clause_tracker_memory "
                  "tracks one step at a time");
    query = query + clause_memory(h2Before).unsqueeze(0);
  }

  const torch::Tensor advances =
      torch::arange(kClauseAdvances, clauseOf.options()).unsqueeze(0);
  torch::Tensor pointer =
      inputs.clause_start.defined()
          ? inputs.clause_start.to(device, torch::kLong).reshape({batch})
          : torch::zeros({batch}, clauseOf.options());
  pointer = torch::minimum(pointer, counts - 1);
  const bool teacher = inputs.clause_targets.defined();
  torch::Tensor targets, followers;
  if (teacher) {
    // within the clauses of the words the policy reads (-1 stays -1)
    targets =
        inputs.clause_targets.to(device, torch::kLong).reshape({steps, batch});
    targets =
        torch::where(targets.ge(0),
                     torch::minimum(targets, counts.unsqueeze(0) - 1), targets);
    out.clause_targets = targets;
    followers =
        inputs.clause_teacher.defined()
            ? inputs.clause_teacher.to(device, torch::kBool).reshape({batch})
            : torch::ones({batch}, clauseOf.options().dtype(torch::kBool));
  }
  std::vector<torch::Tensor> logits, before, read;
  for (int64_t t = 0; t < steps; ++t) {
    const torch::Tensor index = pointer.unsqueeze(1) + advances;  // [B, A]
    const torch::Tensor valid = index.lt(counts.unsqueeze(1));
    const torch::Tensor reached =
        torch::gather(clauses, 1,
                      torch::minimum(index, counts.unsqueeze(1) - 1)
                          .unsqueeze(2)
                          .expand({batch, kClauseAdvances, H}));
    const torch::Tensor z =
        clause_score(torch::tanh(query[t].unsqueeze(1) + reached +
                                 clause_advance.unsqueeze(0)))
            .squeeze(2)
            .masked_fill(valid.logical_not(),
                         -std::numeric_limits<float>::infinity());
    before.push_back(pointer);
    torch::Tensor next = pointer + z.detach().argmax(1);
    if (teacher) next = torch::where(followers, targets[t].clamp_min(0), next);
    logits.push_back(z);
    read.push_back(next);
    pointer = next;
  }
  out.clause_logits = torch::stack(logits);
  out.clause_before = torch::stack(before);
  out.clause_pointer = torch::stack(read);
  // the words of clauses p_t .. p_t + window - 1: [n, L]
  const torch::Tensor first = out.clause_pointer.reshape({steps * batch, 1});
  const torch::Tensor tokens = repeatOverSteps(clauseOf, steps);
  return tokens.ge(first).logical_and(
      tokens.lt(first + static_cast<int64_t>(config_.clause_window)));
}

WaypointPolicyOutputs WaypointCmaPolicyImpl::forwardStepwise(
    const EncodedInstruction& instruction, const WaypointPolicyInputs& inputs,
    const torch::Tensor& hidden) {
  const int64_t steps = inputs.not_done.size(0);
  auto at = [](const torch::Tensor& t, int64_t s) {
    return t.defined() ? t.slice(0, s, s + 1) : t;
  };
  std::vector<WaypointPolicyOutputs> each;
  torch::Tensor state = hidden, pointer = inputs.clause_start;
  for (int64_t s = 0; s < steps; ++s) {
    WaypointPolicyInputs one{at(inputs.rgb, s),
                             at(inputs.depth, s),
                             at(inputs.candidates, s),
                             at(inputs.candidate_mask, s),
                             at(inputs.prev, s),
                             at(inputs.not_done, s),
                             at(inputs.text_mask, s),
                             inputs.clause_of_token,
                             pointer,
                             at(inputs.clause_targets, s),
                             inputs.clause_teacher,
                             inputs.goal_labels};
    each.push_back(forwardSequence(instruction, one, state));
    state = each.back().hidden;
    pointer = each.back().clause_pointer.squeeze(0);
  }
  // the steps' outputs joined along the steps
  auto join = [&](torch::Tensor WaypointPolicyOutputs::*field) {
    if (!(each.front().*field).defined()) return torch::Tensor();
    std::vector<torch::Tensor> parts;
    for (const WaypointPolicyOutputs& o : each) parts.push_back(o.*field);
    return torch::cat(parts, 0);
  };
  WaypointPolicyOutputs out;
  for (auto field : kPerStepOutputs) out.*field = join(field);
  out.hidden = state;
  return out;
}

WaypointPolicyOutputs WaypointCmaPolicyImpl::forwardSequence(
    const EncodedInstruction& instruction, const WaypointPolicyInputs& inputs,
    const torch::Tensor& hidden) {
  VLN_CHECK_ARG(inputs.not_done.dim() == 2,
                "WaypointCmaPolicy: not_done must be [T, B], got ",
                inputs.not_done.sizes());
  const int64_t steps = inputs.not_done.size(0);
  const int64_t batch = inputs.not_done.size(1);
  const int64_t n = steps * batch;
  if (clause_memory && steps > 1)
    return forwardStepwise(instruction, inputs, hidden);
  const int64_t H = config_.hidden_size;
  const int64_t K = inputs.candidate_mask.size(-1);
  VLN_CHECK_ARG(hidden.dim() == 3 && hidden.size(0) == batch &&
                    hidden.size(1) == 2 && hidden.size(2) == H,
                "WaypointCmaPolicy: hidden must be [", batch, ", 2, ", H,
                "], got ", hidden.sizes());

  const torch::Tensor goal =
      goal_stop ? matchGoal(inputs, steps, batch) : torch::Tensor();
  const torch::Tensor views = encodeViews(inputs, n, goal);  // [n, N, H]
  const torch::Tensor notDone = inputs.not_done.reshape({n, 1});
  const torch::Tensor prevFeatures = torch::cat(
      {polarFeatures(inputs.prev.reshape({n, 2}), config_.heading_harmonics) *
           notDone,
       1.0 - notDone},
      1);
  const torch::Tensor prev = torch::relu(prev_linear(prevFeatures));

  const torch::Tensor gru1In =
      torch::cat({views.mean(1), prev}, 1).view({steps, batch, -1});
  auto [h1Seq, h1Last] =
      state_encoder(gru1In, hidden.select(1, 0), inputs.not_done);
  const torch::Tensor h1 = h1Seq.reshape({n, H});

  WaypointPolicyOutputs out;
  std::vector<torch::Tensor> context{h1};
  torch::Tensor visualQuery, textWeights;
  torch::Tensor textKeys, textStates, textMask;  // [n, L, ..]
  if (config_.usesInstruction()) {
    // the instruction rows repeat over the T steps
    textKeys = repeatOverSteps(instruction.keys, steps);
    textStates = repeatOverSteps(instruction.states, steps);
    textMask = repeatOverSteps(instruction.mask, steps);
    torch::Tensor readable;  // [n, L]: the words each step may read
    if (clause_score) {
      // GRU2's state before the step, zero at an episode's start
      const torch::Tensor h2Before =
          clause_memory ? hidden.select(1, 1) * notDone : torch::Tensor();
      readable =
          trackClauses(instruction, inputs, h1, h2Before, steps, batch, out);
    } else if (inputs.text_mask.defined()) {
      const int64_t L = textMask.size(1);
      VLN_CHECK_ARG(inputs.text_mask.size(-1) >= L,
                    "WaypointCmaPolicy: text_mask has ",
                    inputs.text_mask.size(-1), " columns for ", L, " tokens");
      readable = inputs.text_mask.reshape({n, -1}).slice(1, 0, L);
    }
    if (readable.defined()) {
      const torch::Tensor allowed = textMask.logical_and(readable);
      // a decision that may read none of its words reads them all
      textMask = torch::where(allowed.any(1, true), allowed, textMask);
    }
    // text_attention reports the leg attention when there is one
    const torch::Tensor text = attend(state_q(h1), textKeys, textStates,
                                      textMask, leg_q ? nullptr : &textWeights);
    context.push_back(text);
    if (leg_q)
      context.push_back(
          attend(leg_q(h1), textKeys, textStates, textMask, &textWeights));
    visualQuery = text_q(text);
  } else {
    visualQuery = visual_query.unsqueeze(0).expand({n, H});
  }
  const torch::Tensor visual = attend(visualQuery, views, views, {});
  context.push_back(visual);

  const torch::Tensor compressed = torch::relu(
      second_state_compress(torch::cat({torch::cat(context, 1), prev}, 1)));
  auto [h2Seq, h2Last] = second_state_encoder(
      compressed.view({steps, batch, H}), hidden.select(1, 1), inputs.not_done);
  const torch::Tensor h2 = h2Seq.reshape({n, H});
  context[0] = h2;
  const torch::Tensor query =
      query_linear(trainingDropout(torch::cat(context, 1)));  // [n, H]

  // each candidate reads the view nearest its heading
  const torch::Tensor polar = inputs.candidates.reshape({n, K, 2});
  const torch::Tensor viewIndex =
      torch::remainder(torch::round(polar.select(2, 0) * (numViews_ / kTwoPi)),
                       numViews_)
          .to(torch::kLong);
  const torch::Tensor candidateViews =
      torch::gather(views, 1, viewIndex.unsqueeze(2).expand({n, K, H}));
  torch::Tensor candidateKeys = candidate_linear(torch::cat(
      {candidateViews, polarFeatures(polar, config_.heading_harmonics)},
      2));  // [n, K, H]
  if (candidate_text_q) {
    // each candidate's own attention over the words: scores [n, K, L]
    torch::Tensor scores =
        torch::bmm(candidate_text_q(candidateKeys), textKeys.transpose(1, 2)) /
        std::sqrt(static_cast<double>(H));
    scores = scores.masked_fill(textMask.logical_not().unsqueeze(1),
                                -std::numeric_limits<float>::infinity());
    const torch::Tensor words =
        torch::bmm(torch::softmax(scores, 2), textStates);
    candidateKeys = candidateKeys + candidate_text_linear(words);
  }
  torch::Tensor stopKey = stop_key.view({1, 1, H}).expand({n, 1, H});
  if (goal_stop)  // the goal's best match over the views, and what is named
    stopKey = stopKey + goal_stop(std::get<0>(goal.max(1))).unsqueeze(1);
  const torch::Tensor keys =
      torch::cat({stopKey, candidateKeys}, 1);  // [n, 1 + K, H]
  torch::Tensor logits = torch::bmm(keys, query.unsqueeze(2)).squeeze(2) /
                         std::sqrt(static_cast<double>(H));
  const torch::Tensor valid =
      torch::cat({torch::ones({n, 1}, inputs.candidate_mask.options()),
                  inputs.candidate_mask.reshape({n, K})},
                 1);
  logits = logits.masked_fill(valid.logical_not(),
                              -std::numeric_limits<float>::infinity());

  out.logits = logits.view({steps, batch, K + 1});
  if (textWeights.defined())
    out.text_attention = textWeights.view({steps, batch, -1});
  out.hidden = torch::stack({h1Last, h2Last}, 1);
  if (progress_monitor)
    out.progress = torch::tanh(progress_monitor(h2)).view({steps, batch});
  return out;
}

WaypointPolicyOutputs WaypointCmaPolicyImpl::step(
    const EncodedInstruction& instruction, const WaypointPolicyInputs& inputs,
    const torch::Tensor& hidden) {
  auto seq = [](const torch::Tensor& t) {
    return t.defined() ? t.unsqueeze(0) : t;
  };
  // clause_of_token, clause_start and clause_teacher are per episode
  WaypointPolicyInputs one{seq(inputs.rgb),        seq(inputs.depth),
                           seq(inputs.candidates), seq(inputs.candidate_mask),
                           seq(inputs.prev),       seq(inputs.not_done),
                           seq(inputs.text_mask),  inputs.clause_of_token,
                           inputs.clause_start,    seq(inputs.clause_targets),
                           inputs.clause_teacher,  inputs.goal_labels};
  WaypointPolicyOutputs out = forwardSequence(instruction, one, hidden);
  for (auto field : kPerStepOutputs)
    if ((out.*field).defined()) out.*field = (out.*field).squeeze(0);
  return out;
}

torch::Tensor WaypointCmaPolicyImpl::initialHidden(int64_t batch) const {
  const torch::Device device = view_linear->weight.device();
  return torch::zeros({batch, 2, config_.hidden_size},
                      torch::TensorOptions().device(device));
}

void WaypointCmaPolicyImpl::setWordEmbeddings(const torch::Tensor& matrix) {
  if (!config_.usesInstruction()) return;
  instruction_encoder->setWordEmbeddings(matrix);
}

}  // namespace vln::models
