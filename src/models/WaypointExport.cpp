#include "models/WaypointExport.h"

#include <cmath>

#include "common/Check.h"
#include "models/ExportCodegen.h"

namespace vln::models {
namespace {

constexpr const char* kWho = "exportWaypointPolicy()";
constexpr double kTwoPi = 6.283185307179586;

int64_t flatSize(const FeatureShape& shape) {
  return shape[0] * shape[1] * shape[2];
}

// the policy's sizes, as the generated code needs them
struct Sizes {
  std::string views;   // N
  std::string hidden;  // H
  std::string rgb;     // F_rgb (empty with no_rgb)
  std::string depth;   // F_depth (empty with no_depth)
  std::string scale;   // sqrt(H): attention and logits divide by it
};

Sizes sizesOf(const WaypointCmaPolicyImpl& policy) {
  const ModelConfig& c = policy.config();
  Sizes s;
  s.views = std::to_string(policy.numViews());
  s.hidden = std::to_string(c.hidden_size);
  if (c.usesRgb()) s.rgb = std::to_string(policy.rgbFeatures());
  if (c.usesDepth()) s.depth = std::to_string(policy.depthFeatures());
  s.scale = floatLiteral(std::sqrt(static_cast<double>(c.hidden_size)));
  return s;
}

// the expression of sin, cos of m * `heading` for m = 1 .. harmonics stacked
// on `dim`, as WaypointCmaPolicy's headingFeatures()
std::string headingFeatures(const std::string& heading, int harmonics,
                            int dim) {
  std::string parts;
  for (int m = 1; m <= harmonics; ++m) {
    const std::string angle =
        m == 1 ? heading : "(" + heading + " * " + floatLiteral(m) + ")";
    parts += (m == 1 ? "" : ", ") + std::string("torch.sin(") + angle +
             "), torch.cos(" + angle + ")";
  }
  return "torch.stack([" + parts + "], " + std::to_string(dim) + ")";
}

// the heading's features, then distance / 3, on `dim`, as
// WaypointCmaPolicy's polarFeatures()
std::string polarFeatures(const std::string& heading,
                          const std::string& distance, int harmonics, int dim) {
  return "torch.cat([" + headingFeatures(heading, harmonics, dim) + ", (" +
         distance + " / 3.0).unsqueeze(" + std::to_string(dim) + ")], " +
         std::to_string(dim) + ")";
}

// the arguments step_features and forward take after the instruction (with
// model.goal_match the goal's labels first, which the caller computes from
// the instruction's text as it computes the tokens): typed for the
// signature, or as passed on
std::string argumentsAfterInstruction(const ModelConfig& config, bool typed) {
  std::vector<std::string> names = {"candidates", "candidate_mask", "prev",
                                    "not_done", "hidden"};
  if (config.goal_match) names.insert(names.begin(), "goal_labels");
  std::string out;
  for (const std::string& name : names)
    out += (out.empty() ? "" : ", ") + name + (typed ? ": Tensor" : "");
  return out;
}

// goal [n, N, 2 * kGoalGroups] from the RGB features (label
// probabilities): per view the highest probability of a label of each
// group the goal clause names, then whether it names one, as
// WaypointCmaPolicyImpl::matchGoal() for one step
void emitGoalMatch(ScriptWriter& w, const Sizes& s) {
  w.line(1, "labels = rgb_features.to({f32}).reshape([n, " + s.views + ", " +
                s.rgb + "])");
  w.line(1, "groups = goal_labels.to({f32}).reshape([n, " + s.rgb + "])");
  w.line(1, "matched: List[Tensor] = []");
  w.line(1, "named: List[Tensor] = []");
  w.line(1, "for g in range(1, " + std::to_string(kGoalGroups + 1) + "):");
  w.line(2, "in_group = groups == float(g)");
  // probabilities are >= 0, so labels outside the group count as 0
  w.line(2,
         "matched.append(torch.amax(labels * in_group.unsqueeze(1).to({f32}), "
         "[2]))");
  w.line(2, "named.append(torch.any(in_group, 1, True).to({f32}).expand([n, " +
                s.views + "]))");
  w.line(1, "goal = torch.stack(matched + named, 2)");
}

// step_features: WaypointCmaPolicyImpl::forwardSequence() for one step,
// block for block
void emitStep(ScriptWriter& w, const WaypointCmaPolicyImpl& policy) {
  const ModelConfig& config = policy.config();
  const Sizes s = sizesOf(policy);
  w.line(0,
         "def step_features(self, rgb_features: Tensor, depth_features: "
         "Tensor, instruction: Tensor, " +
             argumentsAfterInstruction(config, /*typed=*/true) +
             ") -> Tuple[Tensor, Tensor]:");
  w.line(1, "n = not_done.size(0)");
  w.line(1, "mask = not_done.to({f32}).unsqueeze(1)");

  // views [n, N, H]: each view's projected features (with model.goal_match
  // the RGB features' match with the goal instead) and its heading
  w.line(1, "parts: List[Tensor] = []");
  if (config.goal_match) {
    emitGoalMatch(w, s);
    w.line(1, "parts.append(goal)");
  } else if (config.usesRgb()) {
    w.line(1, "parts.append(torch.relu(" +
                  linear(w, "policy.rgb_linear",
                         "rgb_features.to({f32}).reshape([n, " + s.views +
                             ", " + s.rgb + "])") +
                  "))");
  }
  if (config.usesDepth())
    w.line(1, "parts.append(torch.relu(" +
                  linear(w, "policy.depth_linear",
                         "depth_features.to({f32}).reshape([n, " + s.views +
                             ", " + s.depth + "])") +
                  "))");
  w.line(1, "angles = torch.arange(" + s.views +
                ", dtype={f32}, device=mask.device) * " +
                floatLiteral(kTwoPi / static_cast<double>(policy.numViews())));
  w.line(1, "parts.append(" +
                headingFeatures("angles", config.heading_harmonics, 1) +
                ".unsqueeze(0).expand([n, " + s.views + ", " +
                std::to_string(2 * config.heading_harmonics) + "]))");
  w.line(1, "views = torch.relu(" +
                linear(w, "policy.view_linear", "torch.cat(parts, 2)") + ")");

  // the previous decision (zeros and start = 1 at an episode's start)
  w.line(1, "prev_polar = prev.to({f32})");
  w.line(1, "prev_in = torch.cat([" +
                polarFeatures("prev_polar[:, 0]", "prev_polar[:, 1]",
                              config.heading_harmonics, 1) +
                " * mask, 1.0 - mask], 1)");
  w.line(1, "prev_e = torch.relu(" +
                linear(w, "policy.prev_linear", "prev_in") + ")");
  w.line(1, "h1 = " + gruStep(w, "policy.state_encoder",
                              "torch.cat([views.mean(1), prev_e], 1)",
                              "hidden[:, 0]", "mask"));

  // instruction attention (or the learned visual query without one)
  w.line(1, "context: List[Tensor] = [h1]");
  if (config.usesInstruction()) {
    w.line(1, "encoded = self.encode_instruction(instruction)");
    w.line(1, "states = encoded[0]");
    w.line(1, "keys = " + linear(w, "policy.text_k", "states"));
    w.line(1, "q = " + linear(w, "policy.state_q", "h1"));
    w.line(1,
           "scores = torch.bmm(keys, q.unsqueeze(2)).squeeze(2) / " + s.scale);
    w.line(1,
           "scores = scores.masked_fill(encoded[1].logical_not(), "
           "float(\"-inf\"))");
    w.line(1,
           "text = torch.bmm(torch.softmax(scores, 1).unsqueeze(1), "
           "states).squeeze(1)");
    w.line(1, "context.append(text)");
    if (config.leg_attention) {
      // the second attention (model.leg_attention), after the first
      w.line(1, "q_leg = " + linear(w, "policy.leg_q", "h1"));
      w.line(1,
             "scores_leg = torch.bmm(keys, q_leg.unsqueeze(2)).squeeze(2) / " +
                 s.scale);
      w.line(1,
             "scores_leg = scores_leg.masked_fill(encoded[1].logical_not(), "
             "float(\"-inf\"))");
      w.line(1,
             "context.append(torch.bmm(torch.softmax(scores_leg, 1)."
             "unsqueeze(1), states).squeeze(1))");
    }
    w.line(1, "vq = " + linear(w, "policy.text_q", "text"));
  } else {
    w.line(1, "vq = " + w.ref("policy.visual_query") +
                  ".unsqueeze(0).expand([n, " + s.hidden + "])");
  }
  // attention over the views, which are keys and values alike
  w.line(1, "scores_v = torch.bmm(views, vq.unsqueeze(2)).squeeze(2) / " +
                s.scale);
  w.line(1,
         "context.append(torch.bmm(torch.softmax(scores_v, 1).unsqueeze(1), "
         "views).squeeze(1))");
  w.line(1, "x = torch.relu(" +
                linear(w, "policy.second_state_compress",
                       "torch.cat(context + [prev_e], 1)") +
                ")");
  w.line(1, "h2 = " + gruStep(w, "policy.second_state_encoder", "x",
                              "hidden[:, 1]", "mask"));
  w.line(1, "context[0] = h2");
  w.line(1, "query = " +
                linear(w, "policy.query_linear", "torch.cat(context, 1)"));

  // candidate keys: the view nearest each candidate's heading, its polar
  // features; STOP's key first
  w.line(1, "polar = candidates.to({f32})");
  w.line(1, "k = polar.size(1)");
  w.line(1, "heading = polar[:, :, 0]");
  w.line(1, "view_index = torch.remainder(torch.round(heading * " +
                floatLiteral(static_cast<double>(policy.numViews()) / kTwoPi) +
                "), " + s.views + ").to({i64})");
  w.line(1,
         "candidate_views = torch.gather(views, 1, "
         "view_index.unsqueeze(2).expand([n, k, " +
             s.hidden + "]))");
  w.line(1, "candidate_in = torch.cat([candidate_views, " +
                polarFeatures("heading", "polar[:, :, 1]",
                              config.heading_harmonics, 2) +
                "], 2)");
  w.line(1,
         "cand_keys = " + linear(w, "policy.candidate_linear", "candidate_in"));
  if (config.candidate_text) {
    // each candidate's own attention over the words (model.candidate_text)
    w.line(1, "scores_c = torch.bmm(" +
                  linear(w, "policy.candidate_text_q", "cand_keys") +
                  ", keys.transpose(1, 2)) / " + s.scale);
    w.line(1,
           "scores_c = scores_c.masked_fill(encoded[1].logical_not()."
           "unsqueeze(1), float(\"-inf\"))");
    w.line(1, "cand_keys = cand_keys + " +
                  linear(w, "policy.candidate_text_linear",
                         "torch.bmm(torch.softmax(scores_c, 2), states)"));
  }
  w.line(1, "stop = " + w.ref("policy.stop_key") + ".view([1, 1, " + s.hidden +
                "]).expand([n, 1, " + s.hidden + "])");
  // with model.goal_match the goal's best match over the views, and what is
  // named, move STOP's key
  if (config.goal_match)
    w.line(1, "stop = stop + " +
                  linear(w, "policy.goal_stop", "torch.amax(goal, [1])") +
                  ".unsqueeze(1)");
  w.line(1, "keys_c = torch.cat([stop, cand_keys], 1)");
  w.line(1, "logits = torch.bmm(keys_c, query.unsqueeze(2)).squeeze(2) / " +
                s.scale);
  w.line(1, "real = candidate_mask != 0");
  w.line(1,
         "valid = torch.cat([torch.ones([n, 1], dtype={bool}, "
         "device=real.device), real], 1)");
  w.line(1,
         "logits = logits.masked_fill(valid.logical_not(), float(\"-inf\"))");
  w.line(1, "return logits, torch.stack([h1, h2], 1)");
  w.line(0, "");
}

// the lines that turn a panorama's raw views (rgb, depth: [b, N, h, w, C])
// into per-view features with the included CNNs (a modality without a CNN
// passes its argument through); `b` must be defined before
void emitPanoramaFeatures(ScriptWriter& w, const WaypointCmaPolicyImpl& policy,
                          const ObservationEncoderImpl& encoder) {
  const std::string views = std::to_string(policy.numViews());
  for (const auto& [name, hasCnn] :
       {std::pair<std::string, bool>{"rgb", !encoder.rgb.is_empty()},
        std::pair<std::string, bool>{"depth", !encoder.depth.is_empty()}})
    w.line(1, name + "_features = " +
                  (hasCnn ? "self.encode_" + name + "(" + name +
                                ".flatten(0, 1)).reshape([b, " + views +
                                ", -1])"
                          : name));
}

// forward: the panorama's raw views through the included CNNs, view by view
void emitForward(ScriptWriter& w, const WaypointCmaPolicyImpl& policy,
                 ObservationEncoderImpl* encoder) {
  const std::string arguments =
      "instruction: Tensor, " +
      argumentsAfterInstruction(policy.config(), /*typed=*/true) +
      ") -> Tuple[Tensor, Tensor]:";
  if (encoder != nullptr) {
    w.line(0, "def forward(self, rgb: Tensor, depth: Tensor, " + arguments);
    w.line(1, "b = not_done.size(0)");
    emitPanoramaFeatures(w, policy, *encoder);
  } else {
    w.line(0,
           "def forward(self, rgb_features: Tensor, depth_features: Tensor, " +
               arguments);
  }
  w.line(1,
         "return self.step_features(rgb_features, depth_features, "
         "instruction, " +
             argumentsAfterInstruction(policy.config(), /*typed=*/false) + ")");
}

// heatmap_features, suppress, propose_features (and propose with an
// encoder): WaypointPredictorImpl::forward(), waypointProbabilities() and
// waypoint::heatmapNms(), block for block
void emitPredictor(ScriptWriter& w, const WaypointCmaPolicyImpl& policy,
                   WaypointPredictorImpl& predictor,
                   const ExportedPredictor& nms,
                   ObservationEncoderImpl* encoder) {
  const Sizes s = sizesOf(policy);
  const bool depth = !predictor.depth_fc.is_empty();
  const bool rgb = !predictor.rgb_fc.is_empty();
  const int64_t bins = kWaypointHeadings / predictor.numViews();
  w.line(0,
         "def heatmap_features(self, rgb_features: Tensor, depth_features: "
         "Tensor) -> Tensor:");
  w.line(1, std::string("b = ") + (depth ? "depth" : "rgb") +
                "_features.size(0)");
  if (depth)
    w.line(1, "d = torch.relu(" +
                  linear(w, "predictor.depth_fc.0",
                         "depth_features.to({f32}).reshape([b, " + s.views +
                             ", " + s.depth + "])") +
                  ")");
  if (rgb)
    w.line(1, "r = torch.relu(" +
                  linear(w, "predictor.rgb_fc.0",
                         "rgb_features.to({f32}).reshape([b, " + s.views +
                             ", " + s.rgb + "])") +
                  ")");
  if (depth && rgb)
    w.line(1, "x = torch.relu(" +
                  linear(w, "predictor.merge.0", "torch.cat([d, r], -1)") +
                  ")");
  else
    w.line(1, std::string("x = ") + (depth ? "d" : "r"));
  // the transformer layers, unrolled (post-norm, eval mode: no dropout)
  for (size_t i = 0; i < predictor.layers->size(); ++i) {
    const auto* layer = predictor.layers->ptr(i)->as<ViewAttentionLayerImpl>();
    const std::string p = "predictor.layers." + std::to_string(i) + ".";
    const int64_t heads = layer->offset_bias.size(0);
    const int64_t hidden = layer->qkv->weight.size(1);
    const std::string h = std::to_string(hidden);
    const std::string hs = std::to_string(hidden / heads);
    const std::string views = s.views;
    w.line(1, "parts = " + linear(w, p + "qkv", "x") + ".view([b, " + views +
                  ", 3, " + std::to_string(heads) + ", " + hs + "])");
    w.line(1, "q = parts.select(2, 0).transpose(1, 2)");
    w.line(1, "k = parts.select(2, 1).transpose(1, 2)");
    w.line(1, "v = parts.select(2, 2).transpose(1, 2)");
    w.line(1, "bias = " + w.ref(p + "offset_bias") + ".index_select(1, " +
                  w.ref(p + "offsets") + ".reshape([-1])).view([" +
                  std::to_string(heads) + ", " + views + ", " + views + "])");
    w.line(1, "scores = torch.matmul(q, k.transpose(-2, -1)) / " +
                  floatLiteral(std::sqrt(static_cast<double>(hidden / heads))) +
                  " + bias.unsqueeze(0) + " + w.ref(p + "mask"));
    w.line(1,
           "context = torch.matmul(torch.softmax(scores, -1), "
           "v).transpose(1, 2).reshape([b, " +
               views + ", " + h + "])");
    auto norm = [&](const std::string& name, const std::string& input) {
      return "torch.layer_norm(" + input + ", [" + h + "], " +
             w.ref(p + name + ".weight") + ", " + w.ref(p + name + ".bias") +
             ", " + floatLiteral(layer->norm1->options.eps()) + ")";
    };
    w.line(1, "y = " + norm("norm1", "x + " + linear(w, p + "out", "context")));
    w.line(1, "x = " + norm("norm2",
                            "y + " + linear(w, p + "ff2",
                                            "torch.gelu(" +
                                                linear(w, p + "ff1", "y") +
                                                ")")));
  }
  w.line(1, "logits = " +
                linear(w, "predictor.head.2",
                       "torch.relu(" + linear(w, "predictor.head.0", "x") +
                           ")"));
  // view k's output j sits at bin k * bins + j, rolled back by half a view
  w.line(1, "logits = torch.roll(logits.reshape([b, " +
                std::to_string(kWaypointHeadings) + ", " +
                std::to_string(kWaypointDistances) + "]), [" +
                std::to_string(-(bins / 2)) + "], [1])");
  w.line(1, "return torch.softmax(logits.reshape([b, -1]), 1).view([b, " +
                std::to_string(kWaypointHeadings) + ", " +
                std::to_string(kWaypointDistances) + "])");
  w.line(0, "");

  // greedy suppression: the highest cell, then its box goes to -inf
  const std::string k = std::to_string(nms.max_candidates);
  const std::string last = std::to_string(kWaypointDistances - 1);
  w.line(0,
         "def suppress(self, probabilities: Tensor) -> Tuple[Tensor, "
         "Tensor]:");
  w.line(1, "b = probabilities.size(0)");
  w.line(1, "candidates = torch.zeros([b, " + k +
                ", 2], dtype={f32}, device=probabilities.device)");
  w.line(1, "mask = torch.zeros([b, " + k +
                "], dtype={bool}, device=probabilities.device)");
  w.line(1, "for i in range(b):");
  w.line(2, "cells = probabilities[i].to({f32}).clone()");
  w.line(2, "taken = torch.zeros([" + std::to_string(kWaypointHeadings) +
                "], dtype={bool})");
  w.line(2, "slot = 0");
  w.line(2, "for r in range(" + k + "):");
  w.line(3, "best = int(torch.argmax(cells.reshape([-1])))");
  w.line(3, "h = best // " + std::to_string(kWaypointDistances));
  w.line(3, "d = best % " + std::to_string(kWaypointDistances));
  w.line(3, "if not (float(cells[h, d]) > " + floatLiteral(nms.min_score) +
                "):");
  w.line(4, "break");
  w.line(3, "if not bool(taken[h]):");
  w.line(4, "candidates[i, slot, 0] = self.waypoint_bin_headings[h]");
  w.line(4, "candidates[i, slot, 1] = float(d + 1) * " +
                floatLiteral(kWaypointDistanceStep));
  w.line(4, "mask[i, slot] = True");
  w.line(4, "slot += 1");
  w.line(3, "taken[h] = True");
  w.line(3, "rows = torch.remainder(torch.arange(h - " +
                std::to_string(nms.heading_radius) + ", h + " +
                std::to_string(nms.heading_radius + 1) + ", device=cells.device), " +
                std::to_string(kWaypointHeadings) + ")");
  w.line(3, "lo = max(0, d - " + std::to_string(nms.distance_radius) + ")");
  w.line(3, "hi = min(" + last + ", d + " +
                std::to_string(nms.distance_radius) + ")");
  w.line(3, "cells[:, lo:hi + 1].index_fill_(0, rows, float(\"-inf\"))");
  w.line(1, "return candidates, mask");
  w.line(0, "");

  w.line(0,
         "def propose_features(self, rgb_features: Tensor, depth_features: "
         "Tensor) -> Tuple[Tensor, Tensor]:");
  w.line(1,
         "return self.suppress(self.heatmap_features(rgb_features, "
         "depth_features))");
  w.line(0, "");
  if (encoder != nullptr) {
    w.line(0,
           "def propose(self, rgb: Tensor, depth: Tensor) -> Tuple[Tensor, "
           "Tensor]:");
    w.line(1, "b = rgb.size(0)");
    emitPanoramaFeatures(w, policy, *encoder);
    w.line(1, "return self.propose_features(rgb_features, depth_features)");
    w.line(0, "");
  }
}

// the predictor must read the policy's views and features
void checkPredictor(const WaypointCmaPolicyImpl& policy,
                    const ExportedPredictor& exported) {
  const WaypointPredictorImpl& predictor = *exported.predictor;
  VLN_CHECK_ARG(predictor.numViews() == policy.numViews(), kWho,
                ": the predictor reads ", predictor.numViews(),
                " views, the policy ", policy.numViews());
  VLN_CHECK_ARG(exported.max_candidates >= 0 && exported.heading_radius >= 0 &&
                    exported.distance_radius >= 0,
                kWho,
                ": max_candidates, heading_radius and distance_radius must be "
                ">= 0, got ",
                exported.max_candidates, ", ", exported.heading_radius, ", ",
                exported.distance_radius);
  const ModelConfig& c = policy.config();
  auto check = [&](const torch::nn::Sequential& fc, bool used,
                   int64_t policyReads, const char* what) {
    if (fc.is_empty()) return;
    VLN_CHECK_ARG(used, kWho, ": the predictor reads ", what,
                  " features, the policy has none");
    const int64_t reads = fc->ptr(0)->as<torch::nn::LinearImpl>()->weight.size(1);
    VLN_CHECK_ARG(reads == policyReads, kWho, ": the predictor reads ", reads,
                  " ", what, " features per view, the policy ", policyReads);
  };
  check(predictor.depth_fc, c.usesDepth(), policy.depthFeatures(), "depth");
  check(predictor.rgb_fc, c.usesRgb(), policy.rgbFeatures(), "RGB");
}

// the encoder's features must be what the policy's projections read
void checkEncoder(const WaypointCmaPolicyImpl& policy,
                  const ObservationEncoderImpl& encoder) {
  const ModelConfig& config = policy.config();
  checkEncoderFits(config, encoder.config(), kWho);
  if (config.usesRgb()) {
    const int64_t features = flatSize(rgbFeatureShape(encoder.config()));
    VLN_CHECK_ARG(policy.rgbFeatures() == features, kWho, ": the policy reads ",
                  policy.rgbFeatures(),
                  " RGB features per view, the encoder gives ", features);
  }
  if (config.usesDepth()) {
    const int64_t features = flatSize(depthFeatureShape(encoder.config()));
    VLN_CHECK_ARG(policy.depthFeatures() == features, kWho,
                  ": the policy reads ", policy.depthFeatures(),
                  " depth features per view, the encoder gives ", features);
  }
}

}  // namespace

torch::jit::Module buildWaypointExportModule(
    WaypointCmaPolicyImpl& policy, ObservationEncoderImpl* encoder,
    const ExportedPredictor& predictor) {
  const ModelConfig& config = policy.config();
  VLN_CHECK_ARG(!config.clause_tracker,
                "exportWaypointPolicy(): model.clause_tracker's pointer and "
                "rule clauses are not in the TorchScript archive yet; such a "
                "policy is scored from its checkpoint");
  if (encoder != nullptr) checkEncoder(policy, *encoder);
  if (predictor.predictor != nullptr) checkPredictor(policy, predictor);

  torch::jit::Module root(
      c10::QualifiedName("__torch__.vln.ExportedWaypointPolicy"));
  ScriptWriter w;
  w.addTensors(root, policy, "policy.");
  if (encoder != nullptr) w.addTensors(root, *encoder, "encoder.");
  root.register_attribute("model_config", c10::StringType::get(),
                          common::configToYaml(config));
  root.register_attribute("num_views", c10::IntType::get(), policy.numViews());
  root.register_attribute("has_predictor", c10::BoolType::get(),
                          predictor.predictor != nullptr);
  if (predictor.predictor != nullptr) {
    w.addTensors(root, *predictor.predictor, "predictor.");
    root.register_attribute("max_candidates", c10::IntType::get(),
                            predictor.max_candidates);
    root.register_attribute("nms_heading_radius", c10::IntType::get(),
                            predictor.heading_radius);
    root.register_attribute("nms_distance_radius", c10::IntType::get(),
                            predictor.distance_radius);
    root.register_attribute("nms_min_score", c10::FloatType::get(),
                            predictor.min_score);
    // bin h's heading as waypoint::binHeading() computes it, in float
    std::vector<float> headings(kWaypointHeadings);
    for (int64_t h = 0; h < kWaypointHeadings; ++h)
      headings[static_cast<size_t>(h)] =
          static_cast<float>(h) * kWaypointHeadingStep;
    root.register_buffer("waypoint_bin_headings",
                         torch::tensor(headings, torch::kFloat32));
  }

  if (encoder != nullptr && encoder->rgb) emitRgbEncoder(w, *encoder->rgb);
  if (encoder != nullptr && encoder->depth)
    emitDepthEncoder(w, *encoder->depth);
  if (config.usesInstruction())
    emitInstructionEncoder(w, config, "policy.instruction_encoder");
  emitStep(w, policy);
  emitForward(w, policy, encoder);
  if (predictor.predictor != nullptr)
    emitPredictor(w, policy, *predictor.predictor, predictor, encoder);
  w.compileInto(root, kWho);
  return root;
}

void exportWaypointPolicy(WaypointCmaPolicyImpl& policy,
                          ObservationEncoderImpl* encoder,
                          const std::filesystem::path& file,
                          const ExportedPredictor& predictor) {
  saveScriptModule(buildWaypointExportModule(policy, encoder, predictor), file);
}

}  // namespace vln::models
