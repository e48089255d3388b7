#include "models/Export.h"

#include <cmath>

#include "common/Check.h"
#include "models/CmaPolicy.h"
#include "models/ExportCodegen.h"
#include "models/Seq2SeqPolicy.h"

namespace vln::models {
namespace {

void emitStepHeader(ScriptWriter& w, bool prevAction) {
  w.line(0,
         "def step_features(self, rgb_features: Tensor, depth_features: "
         "Tensor, instruction: Tensor, prev_action: Tensor, not_done: Tensor, "
         "hidden: Tensor) -> Tuple[Tensor, Tensor, Tensor]:");
  w.line(1, "n = not_done.size(0)");
  w.line(1, "mask = not_done.to({f32}).unsqueeze(1)");
  if (prevAction)
    w.line(1, "prev = torch.embedding(" +
                  w.ref("policy.prev_action_embedding.weight") +
                  ", (prev_action + 1) * (not_done != 0).to({i64}))");
}

void emitHeads(ScriptWriter& w, const std::string& state) {
  w.line(1, "logits = " + linear(w, "policy.action_head", state));
  if (w.has("policy.progress_monitor.weight")) {
    w.line(1, "progress = torch.tanh(" +
                  linear(w, "policy.progress_monitor", state) + ").squeeze(1)");
  } else {
    w.line(1,
           "progress = torch.zeros([n], dtype={f32}, "
           "device=logits.device)");
  }
}

void emitSeq2Seq(ScriptWriter& w, const ModelConfig& config) {
  emitStepHeader(w, config.seq2seq_prev_action);
  w.line(1, "parts: List[Tensor] = []");
  if (config.usesInstruction()) {
    w.line(1, "parts.append(self.encode_instruction(instruction)[2])");
  }
  if (config.usesDepth())
    w.line(1, "parts.append(torch.relu(" +
                  linear(w, "policy.depth_linear",
                         "depth_features.to({f32}).flatten(1)") +
                  "))");
  if (config.usesRgb())
    w.line(1, "parts.append(torch.relu(" +
                  linear(w, "policy.rgb_linear",
                         "rgb_features.to({f32}).flatten(2).mean(2)") +
                  "))");
  if (config.seq2seq_prev_action) w.line(1, "parts.append(prev)");
  w.line(1, "h = " + gruStep(w, "policy.state_encoder", "torch.cat(parts, 1)",
                             "hidden[:, 0]", "mask"));
  emitHeads(w, "h");
  w.line(1, "return logits, progress, h.unsqueeze(1)");
  w.line(0, "");
}

void emitCma(ScriptWriter& w, const ModelConfig& config, double scale) {
  const std::string half = std::to_string(config.hidden_size / 2);
  const std::string posDim = std::to_string(config.spatial_embedding_dim);
  const std::string scaleText = floatLiteral(scale);

  // visual attention, evaluated as in CmaPolicyImpl::attendVisual()
  if (config.usesRgb() || config.usesDepth()) {
    w.line(0,
           "def attend(self, q: Tensor, feats: Tensor, pos: Tensor, w: "
           "Tensor, b: Tensor, channels: int) -> Tensor:");
    w.line(1, "wk = w[:" + half + "]");
    w.line(1, "wv = w[" + half + ":]");
    w.line(1, "qk = torch.matmul(q, wk)");
    w.line(1,
           "scores = torch.bmm(qk[:, :channels].unsqueeze(1), "
           "feats).squeeze(1) + torch.matmul(qk[:, channels:], pos) + "
           "torch.matmul(q, b[:" +
               half + "]).unsqueeze(1)");
    w.line(1, "alpha = torch.softmax(scores * " + scaleText + ", 1)");
    w.line(1, "att_f = torch.bmm(feats, alpha.unsqueeze(2)).squeeze(2)");
    w.line(1, "att_p = torch.matmul(alpha, pos.t())");
    w.line(1, "return torch.linear(att_f, wv[:, :channels], b[" + half +
                  ":]) + torch.matmul(att_p, wv[:, channels:].t())");
    w.line(0, "");
  }

  emitStepHeader(w, /*prevAction=*/true);
  w.line(1, "gru1_in: List[Tensor] = []");
  if (config.usesRgb()) {
    const FeatureShape s = rgbFeatureShape(config);
    const std::string c = std::to_string(s[0]);
    const std::string positions = std::to_string(s[1] * s[2]);
    const std::string wt = w.ref("policy.rgb_linear.weight");
    w.line(1, "rgb_feats = rgb_features.to({f32}).reshape([n, " + c + ", " +
                  positions + "])");
    w.line(1, "rgb_pos = " + w.ref("policy.rgb_spatial_embedding.weight") +
                  ".view([" + posDim + ", " + positions + "])");
    w.line(1, "gru1_in.append(torch.relu(torch.linear(rgb_feats.mean(2), " +
                  wt + "[:, :" + c + "], " + w.ref("policy.rgb_linear.bias") +
                  " + torch.mv(" + wt + "[:, " + c + ":], rgb_pos.mean(1)))))");
  }
  if (config.usesDepth()) {
    const FeatureShape s = depthFeatureShape(config);
    const std::string c = std::to_string(s[0]);
    const std::string positions = std::to_string(s[1] * s[2]);
    const std::string split = std::to_string(s[0] * s[1] * s[2]);
    const std::string wt = w.ref("policy.depth_linear.weight");
    w.line(1, "depth_feats = depth_features.to({f32}).reshape([n, " + c + ", " +
                  positions + "])");
    w.line(1, "depth_pos = " + w.ref("policy.depth_spatial_embedding.weight") +
                  ".view([" + posDim + ", " + positions + "])");
    w.line(1,
           "gru1_in.append(torch.relu(torch.linear(depth_feats.reshape([n, " +
               split + "]), " + wt + "[:, :" + split + "], " +
               w.ref("policy.depth_linear.bias") + " + torch.mv(" + wt +
               "[:, " + split + ":], depth_pos.flatten()))))");
  }
  w.line(1, "gru1_in.append(prev)");
  if (config.countsTurns()) {
    // turnCounts() for one step; the count rides in hidden[:, 2, 0]
    const std::string max = std::to_string(kMaxTurnCount);
    w.line(1, "count = torch.round(hidden[:, 2, 0]).clamp(-" + max + ", " +
                  max + ")");
    w.line(1, "turned = count + (prev_action == " +
                  std::to_string(kTurnLeftAction) +
                  ").to({f32}) - (prev_action == " +
                  std::to_string(kTurnRightAction) + ").to({f32})");
    w.line(1, "count = torch.where(prev_action == " +
                  std::to_string(kMoveForwardAction) +
                  ", torch.zeros_like(count), turned)");
    w.line(1,
           "count = torch.where(not_done != 0, count, "
           "torch.zeros_like(count)).clamp(-" +
               max + ", " + max + ")");
    w.line(1, "turns = torch.embedding(" +
                  w.ref("policy.turn_count_embedding.weight") + ", (count + " +
                  max + ").to({i64}))");
    w.line(1, "gru1_in.append(turns)");
  }
  w.line(1, "h1 = " + gruStep(w, "policy.state_encoder",
                              "torch.cat(gru1_in, 1)", "hidden[:, 0]", "mask"));
  w.line(1, "compress_in: List[Tensor] = [h1]");
  if (config.usesInstruction()) {
    w.line(1, "encoded = self.encode_instruction(instruction)");
    w.line(1, "states = encoded[0]");
    w.line(1, "keys = " + linear(w, "policy.text_k", "states"));
    w.line(1, "q = " + linear(w, "policy.state_q", "h1"));
    w.line(1, "scores = torch.bmm(keys, q.unsqueeze(2)).squeeze(2) * " +
                  scaleText);
    w.line(1,
           "scores = scores.masked_fill(encoded[1].logical_not(), "
           "float(\"-inf\"))");
    w.line(1, "alpha = torch.softmax(scores, 1)");
    w.line(1, "text = torch.bmm(alpha.unsqueeze(1), states).squeeze(1)");
    w.line(1, "compress_in.append(text)");
    w.line(1, "vq = " + linear(w, "policy.text_q", "text"));
  } else if (config.usesRgb() || config.usesDepth()) {
    w.line(1, "vq = " + w.ref("policy.visual_query") +
                  ".unsqueeze(0).expand([n, " + half + "])");
  }
  if (config.usesRgb())
    w.line(1, "compress_in.append(self.attend(vq, rgb_feats, rgb_pos, " +
                  w.ref("policy.rgb_kv.weight") + ", " +
                  w.ref("policy.rgb_kv.bias") + ", " +
                  std::to_string(rgbFeatureShape(config)[0]) + "))");
  if (config.usesDepth())
    w.line(1, "compress_in.append(self.attend(vq, depth_feats, depth_pos, " +
                  w.ref("policy.depth_kv.weight") + ", " +
                  w.ref("policy.depth_kv.bias") + ", " +
                  std::to_string(depthFeatureShape(config)[0]) + "))");
  w.line(1, "compress_in.append(prev)");
  if (config.countsTurns()) w.line(1, "compress_in.append(turns)");
  w.line(1, "x = torch.relu(" +
                linear(w, "policy.second_state_compress",
                       "torch.cat(compress_in, 1)") +
                ")");
  w.line(1, "h2 = " + gruStep(w, "policy.second_state_encoder", "x",
                              "hidden[:, 1]", "mask"));
  emitHeads(w, "h2");
  if (config.countsTurns()) {
    w.line(1, "count_row = torch.cat([count.unsqueeze(1), torch.zeros([n, " +
                  std::to_string(config.hidden_size - 1) +
                  "], dtype={f32}, device=count.device)], 1)");
    w.line(1, "return logits, progress, torch.stack([h1, h2, count_row], 1)");
  } else {
    w.line(1, "return logits, progress, torch.stack([h1, h2], 1)");
  }
  w.line(0, "");
}

}  // namespace

torch::jit::Module buildExportModule(PolicyImpl& policy,
                                     ObservationEncoderImpl* encoder) {
  const ModelConfig& config = policy.config();
  if (encoder != nullptr)
    checkEncoderFits(config, encoder->config(), "exportPolicy()");

  // every tensor of both modules, on the CPU, float32, by flattened name
  torch::jit::Module root(c10::QualifiedName("__torch__.vln.ExportedPolicy"));
  ScriptWriter w;
  w.addTensors(root, policy, "policy.");
  if (encoder != nullptr) w.addTensors(root, *encoder, "encoder.");
  root.register_attribute("model_config", c10::StringType::get(),
                          common::configToYaml(config));

  if (encoder != nullptr && encoder->rgb) emitRgbEncoder(w, *encoder->rgb);
  if (encoder != nullptr && encoder->depth)
    emitDepthEncoder(w, *encoder->depth);
  if (config.usesInstruction())
    emitInstructionEncoder(w, config, "policy.instruction_encoder");
  if (config.policy == PolicyType::kCma) {
    emitCma(w, config,
            1.0 / std::sqrt(static_cast<double>(config.hidden_size / 2)));
  } else {
    emitSeq2Seq(w, config);
  }

  // forward: raw observations when the encoders are included
  const std::string outputs = " -> Tuple[Tensor, Tensor, Tensor]:";
  if (encoder != nullptr) {
    w.line(0,
           "def forward(self, rgb: Tensor, depth: Tensor, instruction: "
           "Tensor, prev_action: Tensor, not_done: Tensor, hidden: Tensor)" +
               outputs);
    w.line(1, std::string("rgb_features = ") +
                  (encoder->rgb ? "self.encode_rgb(rgb)" : "rgb"));
    w.line(1, std::string("depth_features = ") +
                  (encoder->depth ? "self.encode_depth(depth)" : "depth"));
  } else {
    w.line(0,
           "def forward(self, rgb_features: Tensor, depth_features: Tensor, "
           "instruction: Tensor, prev_action: Tensor, not_done: Tensor, "
           "hidden: Tensor)" +
               outputs);
  }
  w.line(1,
         "return self.step_features(rgb_features, depth_features, "
         "instruction, prev_action, not_done, hidden)");

  w.compileInto(root, "exportPolicy()");
  return root;
}

void exportPolicy(PolicyImpl& policy, ObservationEncoderImpl* encoder,
                  const std::filesystem::path& file) {
  saveScriptModule(buildExportModule(policy, encoder), file);
}

}  // namespace vln::models
