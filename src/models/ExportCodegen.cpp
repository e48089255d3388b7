#include "models/ExportCodegen.h"

#include <cstdio>
#include <iomanip>

#include "common/Check.h"
#include "common/FileIo.h"
#include "models/StateDict.h"

namespace vln::models {
namespace {

namespace nn = torch::nn;

// "[a, b]" (built with a stream: gcc 12 misreads `"[" + std::to_string(a)`
// under -Wstringop-overflow)
std::string pair(int64_t a, int64_t b) {
  std::ostringstream out;
  out << '[' << a << ", " << b << ']';
  return out.str();
}

void replaceAll(std::string& text, const std::string& from,
                const std::string& to) {
  for (size_t at = text.find(from); at != std::string::npos;
       at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
}

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
    VLN_ASSERT(false && "no TorchScript emitter for this module");
  }
}

}  // namespace

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

std::string floatLiteral(double value) {
  std::ostringstream out;
  out << std::setprecision(17) << value;
  std::string s = out.str();
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

// ===========================================================================
// code writer
// ===========================================================================

void ScriptWriter::addTensors(torch::jit::Module& root, nn::Module& module,
                              const std::string& prefix) {
  std::set<std::string> buffers;
  for (const auto& item : module.named_buffers(/*recurse=*/true))
    buffers.insert(item.key());
  for (const auto& [name, tensor] : namedState(module)) {
    const std::string dotted = prefix + name;
    torch::Tensor copy = tensor.detach().to(torch::kCPU).clone();
    if (copy.is_floating_point()) copy = copy.to(torch::kFloat32);
    root.register_parameter(flatName(dotted), copy,
                            /*is_buffer=*/buffers.count(name) == 1);
    names_.insert(dotted);
  }
}

std::string ScriptWriter::ref(const std::string& dotted) const {
  VLN_ASSERT(names_.count(dotted) == 1);
  return "self." + flatName(dotted);
}

bool ScriptWriter::has(const std::string& dotted) const {
  return names_.count(dotted) == 1;
}

std::string ScriptWriter::fresh(const std::string& stem) {
  return stem + "_" + std::to_string(counter_++);
}

void ScriptWriter::line(int indent, std::string text) {
  replaceAll(text, "{f32}", std::to_string(static_cast<int>(torch::kFloat32)));
  replaceAll(text, "{i64}", std::to_string(static_cast<int>(torch::kInt64)));
  replaceAll(text, "{bool}", std::to_string(static_cast<int>(torch::kBool)));
  code_ << std::string(static_cast<size_t>(indent) * 4, ' ') << text << '\n';
}

void ScriptWriter::compileInto(torch::jit::Module& root,
                               const char* who) const {
  try {
    root.define(code());
  } catch (const std::exception& e) {
    // generated code failing to compile is a bug here, not bad input
    std::fprintf(stderr, "%s: generated TorchScript:\n%s\n%s\n", who,
                 code().c_str(), e.what());
    VLN_ASSERT(false && "generated TorchScript does not compile");
  }
  root.eval();
}

void saveScriptModule(const torch::jit::Module& module,
                      const std::filesystem::path& file) {
  std::ostringstream bytes;
  module.save(bytes);
  common::writeFileAtomic(file, bytes.str());
}

void checkEncoderFits(const ModelConfig& policy, const ModelConfig& encoder,
                      const char* who) {
  VLN_CHECK_ARG(policy.usesRgb() == encoder.usesRgb() &&
                    policy.usesDepth() == encoder.usesDepth(),
                who,
                ": the encoder and the policy disagree on model.no_rgb / "
                "model.no_depth");
  if (policy.usesRgb())
    VLN_CHECK_ARG(rgbFeatureShape(policy) == rgbFeatureShape(encoder), who,
                  ": the encoder's RGB features do not fit the policy "
                  "(model.rgb_encoder differs)");
  if (policy.usesDepth())
    VLN_CHECK_ARG(depthFeatureShape(policy) == depthFeatureShape(encoder), who,
                  ": the encoder's depth features do not fit the policy "
                  "(model.depth_encoder or depth size differs)");
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
  if (rgb.semantic)  // model.rgb_semantic_outputs
    w.line(1, "x = torch.sigmoid(torch.linear(x.flatten(1), " +
                  w.ref("encoder.rgb.semantic.weight") + ", " +
                  w.ref("encoder.rgb.semantic.bias") +
                  ")).view(x.size(0), -1, 1, 1)");
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
// policy parts
// ===========================================================================

// masked (Bi)LSTM over token ids or text features: identical to the packed
// LSTM for every real token, since padded steps never update the state
void emitInstructionEncoder(ScriptWriter& w, const ModelConfig& config,
                            const std::string& prefix) {
  const std::string p = prefix + ".";
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
                    const std::string& input, const std::string& state,
                    const std::string& mask) {
  return "torch.gru_cell(" + input + ", " + state + " * " + mask + ", " +
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

}  // namespace vln::models
