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
  if (c.usesRgb()) s.rgb = std::to_string(policy.rgb_linear->weight.size(1));
  if (c.usesDepth())
    s.depth = std::to_string(policy.depth_linear->weight.size(1));
  s.scale = floatLiteral(std::sqrt(static_cast<double>(c.hidden_size)));
  return s;
}

// the expression of sin, cos, distance / 3 stacked on `dim`, as
// WaypointCmaPolicy's polarFeatures()
std::string polarFeatures(const std::string& heading,
                          const std::string& distance, int dim) {
  return "torch.stack([torch.sin(" + heading + "), torch.cos(" + heading +
         "), " + distance + " / 3.0], " + std::to_string(dim) + ")";
}

// step_features: WaypointCmaPolicyImpl::forwardSequence() for one step,
// block for block
void emitStep(ScriptWriter& w, const WaypointCmaPolicyImpl& policy) {
  const ModelConfig& config = policy.config();
  const Sizes s = sizesOf(policy);
  w.line(0,
         "def step_features(self, rgb_features: Tensor, depth_features: "
         "Tensor, instruction: Tensor, candidates: Tensor, candidate_mask: "
         "Tensor, prev: Tensor, not_done: Tensor, hidden: Tensor) -> "
         "Tuple[Tensor, Tensor]:");
  w.line(1, "n = not_done.size(0)");
  w.line(1, "mask = not_done.to({f32}).unsqueeze(1)");

  // views [n, N, H]: each view's projected features and its heading
  w.line(1, "parts: List[Tensor] = []");
  if (config.usesRgb())
    w.line(1, "parts.append(torch.relu(" +
                  linear(w, "policy.rgb_linear",
                         "rgb_features.to({f32}).reshape([n, " + s.views +
                             ", " + s.rgb + "])") +
                  "))");
  if (config.usesDepth())
    w.line(1, "parts.append(torch.relu(" +
                  linear(w, "policy.depth_linear",
                         "depth_features.to({f32}).reshape([n, " + s.views +
                             ", " + s.depth + "])") +
                  "))");
  w.line(1, "angles = torch.arange(" + s.views +
                ", dtype={f32}, device=mask.device) * " +
                floatLiteral(kTwoPi / static_cast<double>(policy.numViews())));
  w.line(1,
         "parts.append(torch.stack([torch.sin(angles), torch.cos(angles)], "
         "1).unsqueeze(0).expand([n, " +
             s.views + ", 2]))");
  w.line(1, "views = torch.relu(" +
                linear(w, "policy.view_linear", "torch.cat(parts, 2)") + ")");

  // the previous decision (zeros and start = 1 at an episode's start)
  w.line(1, "prev_polar = prev.to({f32})");
  w.line(1, "prev_in = torch.cat([" +
                polarFeatures("prev_polar[:, 0]", "prev_polar[:, 1]", 1) +
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
                polarFeatures("heading", "polar[:, :, 1]", 2) + "], 2)");
  w.line(1, "keys_c = torch.cat([" + w.ref("policy.stop_key") +
                ".view([1, 1, " + s.hidden + "]).expand([n, 1, " + s.hidden +
                "]), " + linear(w, "policy.candidate_linear", "candidate_in") +
                "], 1)");
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

// forward: the panorama's raw views through the included CNNs, view by view
void emitForward(ScriptWriter& w, const WaypointCmaPolicyImpl& policy,
                 ObservationEncoderImpl* encoder) {
  const std::string arguments =
      "instruction: Tensor, candidates: Tensor, candidate_mask: Tensor, "
      "prev: Tensor, not_done: Tensor, hidden: Tensor) -> Tuple[Tensor, "
      "Tensor]:";
  if (encoder != nullptr) {
    const std::string views = std::to_string(policy.numViews());
    w.line(0, "def forward(self, rgb: Tensor, depth: Tensor, " + arguments);
    w.line(1, "b = not_done.size(0)");
    w.line(1, std::string("rgb_features = ") +
                  (encoder->rgb ? "self.encode_rgb(rgb.flatten(0, 1))"
                                  ".reshape([b, " +
                                      views + ", -1])"
                                : "rgb"));
    w.line(1, std::string("depth_features = ") +
                  (encoder->depth ? "self.encode_depth(depth.flatten(0, 1))"
                                    ".reshape([b, " +
                                        views + ", -1])"
                                  : "depth"));
  } else {
    w.line(0,
           "def forward(self, rgb_features: Tensor, depth_features: Tensor, " +
               arguments);
  }
  w.line(1,
         "return self.step_features(rgb_features, depth_features, "
         "instruction, candidates, candidate_mask, prev, not_done, hidden)");
}

// the encoder's features must be what the policy's projections read
void checkEncoder(const WaypointCmaPolicyImpl& policy,
                  const ObservationEncoderImpl& encoder) {
  const ModelConfig& config = policy.config();
  checkEncoderFits(config, encoder.config(), kWho);
  if (config.usesRgb()) {
    const int64_t features = flatSize(rgbFeatureShape(encoder.config()));
    VLN_CHECK_ARG(policy.rgb_linear->weight.size(1) == features, kWho,
                  ": the policy reads ", policy.rgb_linear->weight.size(1),
                  " RGB features per view, the encoder gives ", features);
  }
  if (config.usesDepth()) {
    const int64_t features = flatSize(depthFeatureShape(encoder.config()));
    VLN_CHECK_ARG(policy.depth_linear->weight.size(1) == features, kWho,
                  ": the policy reads ", policy.depth_linear->weight.size(1),
                  " depth features per view, the encoder gives ", features);
  }
}

}  // namespace

torch::jit::Module buildWaypointExportModule(WaypointCmaPolicyImpl& policy,
                                             ObservationEncoderImpl* encoder) {
  const ModelConfig& config = policy.config();
  if (encoder != nullptr) checkEncoder(policy, *encoder);

  torch::jit::Module root(
      c10::QualifiedName("__torch__.vln.ExportedWaypointPolicy"));
  ScriptWriter w;
  w.addTensors(root, policy, "policy.");
  if (encoder != nullptr) w.addTensors(root, *encoder, "encoder.");
  root.register_attribute("model_config", c10::StringType::get(),
                          common::configToYaml(config));
  root.register_attribute("num_views", c10::IntType::get(), policy.numViews());

  if (encoder != nullptr && encoder->rgb) emitRgbEncoder(w, *encoder->rgb);
  if (encoder != nullptr && encoder->depth)
    emitDepthEncoder(w, *encoder->depth);
  if (config.usesInstruction())
    emitInstructionEncoder(w, config, "policy.instruction_encoder");
  emitStep(w, policy);
  emitForward(w, policy, encoder);
  w.compileInto(root, kWho);
  return root;
}

void exportWaypointPolicy(WaypointCmaPolicyImpl& policy,
                          ObservationEncoderImpl* encoder,
                          const std::filesystem::path& file) {
  saveScriptModule(buildWaypointExportModule(policy, encoder), file);
}

}  // namespace vln::models
