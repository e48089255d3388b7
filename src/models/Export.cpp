#include "models/Export.h"

#include <cmath>
#include <cstdio>
#include <iomanip>
#include <set>
#include <sstream>

#include "common/Check.h"
#include "common/FileIo.h"
#include "models/CmaPolicy.h"
#include "models/Seq2SeqPolicy.h"
#include "models/StateDict.h"

namespace vln::models {
namespace {

namespace nn = torch::nn;

// TorchScript attribute name of a dotted tensor name
std::string flatName(const std::string& dotted) {
  std::string out;
  for (char c : dotted) {
    if (c == '.') {
      out += "__";
    } else {
      out += c;
    }
  }
  return out;
}

// a double literal TorchScript parses as float (never as int)
std::string floatLiteral(double value) {
  std::ostringstream out;
  out << std::setprecision(17) << value;
  std::string s = out.str();
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

std::string pair(int64_t a, int64_t b) {
  return "[" + std::to_string(a) + ", " + std::to_string(b) + "]";
}

void replaceAll(std::string& text, const std::string& from,
                const std::string& to) {
  for (size_t at = text.find(from); at != std::string::npos;
       at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
}

// ===========================================================================
// code writer
// ===========================================================================

// Collects the generated TorchScript source and hands out references to
// the tensors registered on the root module.
class ScriptWriter {
 public:
  explicit ScriptWriter(std::set<std::string> names)
      : names_(std::move(names)) {}

  // "self.<flat name>" of a registered tensor
  std::string ref(const std::string& dotted) const {
    VLN_ASSERT(names_.count(dotted) == 1);
    return "self." + flatName(dotted);
  }
  bool has(const std::string& dotted) const {
    return names_.count(dotted) == 1;
  }
  std::string fresh(const std::string& stem) {
    return stem + "_" + std::to_string(counter_++);
  }
  // writes one line; "{f32}" and "{i64}" become dtype numbers, because
  // source compiled from C++ has no Python resolver for torch.float32
  void line(int indent, std::string text) {
    replaceAll(text, "{f32}",
               std::to_string(static_cast<int>(torch::kFloat32)));
    replaceAll(text, "{i64}", std::to_string(static_cast<int>(torch::kInt64)));
    code_ << std::string(static_cast<size_t>(indent) * 4, ' ') << text << '\n';
  }
  std::string code() const { return code_.str(); }

 private:
  std::set<std::string> names_;
  std::ostringstream code_;
  int counter_ = 0;
};

// ===========================================================================
// CNN emitters: `var = module(var)` for every module the encoders use
// ===========================================================================

void emitModule(ScriptWriter& w, nn::Module& module, const std::string& prefix,
                const std::string& var, int indent);

void emitConv(ScriptWriter& w, nn::Conv2dImpl& conv, const std::string& prefix,
              const std::string& var, int indent) {
  const auto& o = conv.options;
  const auto* padding = c10::get_if<torch::ExpandingArray<2>>(&o.padding());
  VLN_ASSERT(padding != nullptr);
  VLN_ASSERT(c10::get_if<torch::enumtype::kZeros>(&o.padding_mode()) !=
             nullptr);
  const std::string bias = o.bias() ? w.ref(prefix + ".bias") : "None";
  w.line(indent, var + " = torch.conv2d(" + var + ", " +
                     w.ref(prefix + ".weight") + ", " + bias + ", " +
                     pair(o.stride()->at(0), o.stride()->at(1)) + ", " +
                     pair((*padding)->at(0), (*padding)->at(1)) + ", " +
                     pair(o.dilation()->at(0), o.dilation()->at(1)) + ", " +
                     std::to_string(o.groups()) + ")");
}

void emitTvBlock(ScriptWriter& w, TvBlockImpl& block, const std::string& p,
                 const std::string& var, int indent) {
  const std::string identity = w.fresh("identity");
  w.line(indent, identity + " = " + var);
  if (block.downsample)
    emitModule(w, *block.downsample, p + ".downsample", identity, indent);
  emitModule(w, *block.conv1, p + ".conv1", var, indent);
  emitModule(w, *block.bn1, p + ".bn1", var, indent);
  w.line(indent, var + " = torch.relu(" + var + ")");
  emitModule(w, *block.conv2, p + ".conv2", var, indent);
  emitModule(w, *block.bn2, p + ".bn2", var, indent);
  if (block.bottleneck) {
    w.line(indent, var + " = torch.relu(" + var + ")");
    emitModule(w, *block.conv3, p + ".conv3", var, indent);
    emitModule(w, *block.bn3, p + ".bn3", var, indent);
  }
  w.line(indent, var + " = torch.relu(" + var + " + " + identity + ")");
}

void emitModule(ScriptWriter& w, nn::Module& module, const std::string& prefix,
                const std::string& var, int indent) {
  if (auto* conv = module.as<nn::Conv2d>()) {
    emitConv(w, *conv, prefix, var, indent);
  } else if (auto* bn = module.as<nn::BatchNorm2d>()) {
    // inference semantics: running statistics
    w.line(indent, var + " = torch.batch_norm(" + var + ", " +
                       w.ref(prefix + ".weight") + ", " +
                       w.ref(prefix + ".bias") + ", " +
                       w.ref(prefix + ".running_mean") + ", " +
                       w.ref(prefix + ".running_var") + ", False, 0.0, " +
                       floatLiteral(bn->options.eps()) + ", False)");
  } else if (auto* gn = module.as<nn::GroupNorm>()) {
    w.line(indent, var + " = torch.group_norm(" + var + ", " +
                       std::to_string(gn->options.num_groups()) + ", " +
                       w.ref(prefix + ".weight") + ", " +
                       w.ref(prefix + ".bias") + ", " +
                       floatLiteral(gn->options.eps()) + ", False)");
  } else if (module.as<nn::ReLU>() != nullptr) {
    w.line(indent, var + " = torch.relu(" + var + ")");
  } else if (module.as<nn::Sequential>() != nullptr) {
    for (const auto& child : module.named_children())
      emitModule(w, *child.value(), prefix + "." + child.key(), var, indent);
  } else if (auto* tvBlock = dynamic_cast<TvBlockImpl*>(&module)) {
    emitTvBlock(w, *tvBlock, prefix, var, indent);
  } else if (auto* tv = dynamic_cast<TorchVisionResNetImpl*>(&module)) {
    emitModule(w, *tv->conv1, prefix + ".conv1", var, indent);
    emitModule(w, *tv->bn1, prefix + ".bn1", var, indent);
    w.line(indent, var + " = torch.relu(" + var + ")");
    w.line(indent,
           var + " = torch.max_pool2d(" + var + ", [3, 3], [2, 2], [1, 1])");
    for (const char* layer : {"layer1", "layer2", "layer3", "layer4"})
      emitModule(w, *tv->named_children()[layer], prefix + "." + layer, var,
                 indent);
  } else if (auto* dBlock = dynamic_cast<DdppoBlockImpl*>(&module)) {
    const std::string identity = w.fresh("identity");
    w.line(indent, identity + " = " + var);
    if (dBlock->downsample)
      emitModule(w, *dBlock->downsample, prefix + ".downsample", identity,
                 indent);
    emitModule(w, *dBlock->convs, prefix + ".convs", var, indent);
    w.line(indent, var + " = torch.relu(" + var + " + " + identity + ")");
  } else if (auto* dd = dynamic_cast<DdppoResNetImpl*>(&module)) {
    emitModule(w, *dd->conv1, prefix + ".conv1", var, indent);
    w.line(indent,
           var + " = torch.max_pool2d(" + var + ", [3, 3], [2, 2], [1, 1])");
    for (const char* layer : {"layer1", "layer2", "layer3", "layer4"})
      emitModule(w, *dd->named_children()[layer], prefix + "." + layer, var,
                 indent);
  } else if (auto* enc = dynamic_cast<DdppoResNetEncoderImpl*>(&module)) {
    w.line(indent, var + " = torch.avg_pool2d(" + var + ", [2, 2])");
    emitModule(w, *enc->backbone, prefix + ".backbone", var, indent);
    emitModule(w, *enc->compression, prefix + ".compression", var, indent);
  } else if (auto* small = dynamic_cast<SmallCnnImpl*>(&module)) {
    emitModule(w, *small->cnn, prefix + ".cnn", var, indent);
    w.line(indent, var + " = torch.adaptive_avg_pool2d(" + var + ", [4, 4])");
  } else {
    VLN_ASSERT(false && "exportPolicy: no TorchScript emitter for a module");
  }
}

// ===========================================================================
// encoders
// ===========================================================================

void emitRgbEncoder(ScriptWriter& w, RgbEncoderImpl& rgb) {
  w.line(0, "def encode_rgb(self, rgb: Tensor) -> Tensor:");
  w.line(1, "x = rgb.permute(0, 3, 1, 2).to({f32})");
  if (rgb.normalizesWithImageNet()) {
    w.line(1,
           "mean = torch.tensor([0.485, 0.456, 0.406], dtype={f32}, "
           "device=x.device).view(1, 3, 1, 1)");
    w.line(1,
           "std = torch.tensor([0.229, 0.224, 0.225], dtype={f32}, "
           "device=x.device).view(1, 3, 1, 1)");
    w.line(1, "x = x * (1.0 / 255.0 / std) - mean / std");
  } else {
    // model.normalize_rgb: false (VLN-CE's encoder)
    w.line(1, "x = x / 255.0");
  }
  emitModule(w, rgb.cnnModule(), "encoder.rgb.cnn", "x", 1);
  if (rgb.resnet) w.line(1, "x = torch.adaptive_avg_pool2d(x, [4, 4])");
  w.line(1, "return x");
  w.line(0, "");
}

void emitDepthEncoder(ScriptWriter& w, DepthEncoderImpl& depth) {
  w.line(0, "def encode_depth(self, depth: Tensor) -> Tensor:");
  w.line(1, "x = depth.permute(0, 3, 1, 2).to({f32})");
  emitModule(w, depth.cnnModule(), "encoder.depth.cnn", "x", 1);
  w.line(1, "return x");
  w.line(0, "");
}

// ===========================================================================
// policies
// ===========================================================================

// masked (Bi)LSTM over token ids or text features: identical to the packed
// LSTM for every real token, since padded steps never update the state
void emitInstructionEncoder(ScriptWriter& w, const ModelConfig& config) {
  const std::string p = "policy.instruction_encoder.";
  const std::string hidden = std::to_string(config.instruction_hidden_size);
  // `tokens` holds text features [B, L, D] with model.instruction_features:
  // rxr_text
  w.line(0,
         "def encode_instruction(self, tokens: Tensor) -> Tuple[Tensor, "
         "Tensor, Tensor]:");
  if (config.usesTextFeatures()) {
    // text features [B, L, D]: a row ends at its last non-zero feature row
    // (InstructionEncoderImpl::featureLengths); the zero rows after it
    // (RxR pads to 512) are dropped
    w.line(1, "real = torch.any(tokens != 0, 2).to({i64})");
    w.line(1,
           "positions = torch.arange(1, real.size(1) + 1, dtype={i64}, "
           "device=tokens.device)");
    w.line(1, "lens = torch.amax(real * positions.unsqueeze(0), [1])");
    w.line(1, "length = int(lens.max())");
    w.line(1, "x = tokens[:, :length].to({f32})");
    w.line(1,
           "mask = torch.arange(length, dtype={i64}, "
           "device=tokens.device).unsqueeze(0) < lens.unsqueeze(1)");
    w.line(1, "m = mask.to({f32}).unsqueeze(2)");
  } else {
    // trailing PAD columns never change the result: drop them (R2R stores
    // instructions padded to 200 tokens)
    w.line(1, "length = int((tokens != 0).sum(1).max())");
    w.line(1, "tokens = tokens[:, :length]");
    w.line(1, "mask = tokens != 0");
    w.line(1, "m = mask.to({f32}).unsqueeze(2)");
    w.line(1, "x = torch.embedding(" + w.ref(p + "embedding.weight") +
                  ", tokens)");
  }
  auto direction = [&](const std::string& suffix, bool reverse,
                       const std::string& list) {
    w.line(1, "h = torch.zeros([tokens.size(0), " + hidden +
                  "], dtype={f32}, device=tokens.device)");
    w.line(1, "c = torch.zeros_like(h)");
    w.line(1, list + ": List[Tensor] = []");
    w.line(1, "for i in range(length):");
    w.line(2, reverse ? "t = length - 1 - i" : "t = i");
    w.line(2, "hc = torch.lstm_cell(x[:, t], [h, c], " +
                  w.ref(p + "lstm.weight_ih_l0" + suffix) + ", " +
                  w.ref(p + "lstm.weight_hh_l0" + suffix) + ", " +
                  w.ref(p + "lstm.bias_ih_l0" + suffix) + ", " +
                  w.ref(p + "lstm.bias_hh_l0" + suffix) + ")");
    w.line(2, "mt = m[:, t]");
    w.line(2, "h = mt * hc[0] + (1.0 - mt) * h");
    w.line(2, "c = mt * hc[1] + (1.0 - mt) * c");
    w.line(2, reverse ? list + ".insert(0, h)" : list + ".append(h)");
  };
  direction("", false, "forward_states");
  w.line(1, "last = h");
  w.line(1, "states = torch.stack(forward_states, 1) * m");
  if (config.policy == PolicyType::kCma) {
    direction("_reverse", true, "backward_states");
    w.line(1,
           "states = torch.cat([states, torch.stack(backward_states, 1) * "
           "m], 2)");
  }
  w.line(1, "return states, mask, last");
  w.line(0, "");
}

// GRU step with the episode-start reset
std::string gruStep(const ScriptWriter& w, const std::string& prefix,
                    const std::string& input, const std::string& state) {
  return "torch.gru_cell(" + input + ", " + state + " * mask, " +
         w.ref(prefix + ".gru.weight_ih_l0") + ", " +
         w.ref(prefix + ".gru.weight_hh_l0") + ", " +
         w.ref(prefix + ".gru.bias_ih_l0") + ", " +
         w.ref(prefix + ".gru.bias_hh_l0") + ")";
}

std::string linear(const ScriptWriter& w, const std::string& prefix,
                   const std::string& input) {
  return "torch.linear(" + input + ", " + w.ref(prefix + ".weight") + ", " +
         w.ref(prefix + ".bias") + ")";
}

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
                             "hidden[:, 0]"));
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
  w.line(1, "h1 = " + gruStep(w, "policy.state_encoder",
                              "torch.cat(gru1_in, 1)", "hidden[:, 0]"));
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
  w.line(1, "x = torch.relu(" +
                linear(w, "policy.second_state_compress",
                       "torch.cat(compress_in, 1)") +
                ")");
  w.line(1, "h2 = " +
                gruStep(w, "policy.second_state_encoder", "x", "hidden[:, 1]"));
  emitHeads(w, "h2");
  w.line(1, "return logits, progress, torch.stack([h1, h2], 1)");
  w.line(0, "");
}

void checkCompatible(const ModelConfig& policy, const ModelConfig& encoder) {
  VLN_CHECK_ARG(policy.usesRgb() == encoder.usesRgb() &&
                    policy.usesDepth() == encoder.usesDepth(),
                "exportPolicy(): the encoder and the policy disagree on "
                "model.no_rgb / model.no_depth");
  if (policy.usesRgb())
    VLN_CHECK_ARG(rgbFeatureShape(policy) == rgbFeatureShape(encoder),
                  "exportPolicy(): the encoder's RGB features do not fit the "
                  "policy (model.rgb_encoder differs)");
  if (policy.usesDepth())
    VLN_CHECK_ARG(depthFeatureShape(policy) == depthFeatureShape(encoder),
                  "exportPolicy(): the encoder's depth features do not fit "
                  "the policy (model.depth_encoder or depth size differs)");
}

}  // namespace

torch::jit::Module buildExportModule(PolicyImpl& policy,
                                     ObservationEncoderImpl* encoder) {
  const ModelConfig& config = policy.config();
  if (encoder != nullptr) checkCompatible(config, encoder->config());

  // every tensor of both modules, on the CPU, float32, by flattened name
  torch::jit::Module root(c10::QualifiedName("__torch__.vln.ExportedPolicy"));
  std::set<std::string> names;
  auto addAll = [&](nn::Module& module, const std::string& prefix) {
    std::set<std::string> buffers;
    for (const auto& item : module.named_buffers(/*recurse=*/true))
      buffers.insert(item.key());
    for (const auto& [name, tensor] : namedState(module)) {
      const std::string dotted = prefix + name;
      torch::Tensor copy = tensor.detach().to(torch::kCPU).clone();
      if (copy.is_floating_point()) copy = copy.to(torch::kFloat32);
      root.register_parameter(flatName(dotted), copy,
                              /*is_buffer=*/buffers.count(name) == 1);
      names.insert(dotted);
    }
  };
  addAll(policy, "policy.");
  if (encoder != nullptr) addAll(*encoder, "encoder.");
  root.register_attribute("model_config", c10::StringType::get(),
                          common::configToYaml(config));

  ScriptWriter w(std::move(names));
  if (encoder != nullptr && encoder->rgb) emitRgbEncoder(w, *encoder->rgb);
  if (encoder != nullptr && encoder->depth)
    emitDepthEncoder(w, *encoder->depth);
  if (config.usesInstruction()) emitInstructionEncoder(w, config);
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

  try {
    root.define(w.code());
  } catch (const std::exception& e) {
    // generated code failing to compile is a bug here, not bad input
    std::fprintf(stderr, "exportPolicy(): generated TorchScript:\n%s\n%s\n",
                 w.code().c_str(), e.what());
    VLN_ASSERT(false && "exportPolicy: generated TorchScript does not compile");
  }
  root.eval();
  return root;
}

void exportPolicy(PolicyImpl& policy, ObservationEncoderImpl* encoder,
                  const std::filesystem::path& file) {
  const torch::jit::Module module = buildExportModule(policy, encoder);
  std::ostringstream bytes;
  module.save(bytes);
  common::writeFileAtomic(file, bytes.str());
}

}  // namespace vln::models
