#pragma once
// The pieces every TorchScript export of this project is generated from
// (Export.h for the low-level agents, WaypointExport.h for the waypoint
// agent): a writer that collects TorchScript source and registers the
// modules' tensors on the archive's root module, and emitters for the
// modules the policies share (the visual encoders' CNNs, the instruction
// encoder, GRU steps, linear layers). Generated code refers to tensors as
// `self.<dotted name with "." replaced by "__">` ("policy__view_linear__
// weight"); the archives are self-contained and need no part of this
// project to run.

#include <torch/script.h>

#include <filesystem>
#include <set>
#include <sstream>
#include <string>

#include "models/ModelConfig.h"
#include "models/ObservationEncoder.h"

namespace vln::models {

/// TorchScript attribute name of a dotted tensor name ("a.b" -> "a__b").
std::string flatName(const std::string& dotted);

/// `value` as a literal TorchScript parses as float, never as int
/// ("1.0", not "1"), with full double precision.
std::string floatLiteral(double value);

/// Collects the generated source of one export and hands out references to
/// the tensors registered on its root module.
class ScriptWriter {
 public:
  /// Registers every parameter and buffer of `module` on `root` under
  /// flatName(prefix + name), as CPU copies (floating tensors in float32),
  /// buffers as buffers, and remembers the names for ref().
  void addTensors(torch::jit::Module& root, torch::nn::Module& module,
                  const std::string& prefix);

  /// "self.<flat name>" of a registered tensor (dotted name); asserts that
  /// it was registered.
  std::string ref(const std::string& dotted) const;
  bool has(const std::string& dotted) const;
  /// A variable name not used before ("identity_3").
  std::string fresh(const std::string& stem);
  /// Appends one line at `indent` levels (4 spaces each); "{f32}",
  /// "{i64}" and "{bool}" become dtype numbers, because source compiled from
  /// C++ has no Python resolver for torch.float32.
  void line(int indent, std::string text);
  std::string code() const { return code_.str(); }

  /// Compiles the collected source into `root` (define()) and puts it in
  /// eval mode. Source that does not compile is a bug of the generator:
  /// prints it with the error and aborts (`who` names the export).
  void compileInto(torch::jit::Module& root, const char* who) const;

 private:
  std::set<std::string> names_;
  std::ostringstream code_;
  int counter_ = 0;
};

/// Atomically writes `module` as a TorchScript archive to `file`.
void saveScriptModule(const torch::jit::Module& module,
                      const std::filesystem::path& file);

/// Throws std::invalid_argument (message starting with `who`) unless
/// `encoder`'s features are the ones `policy` reads: the same modalities
/// (model.no_rgb / no_depth) and feature shapes.
void checkEncoderFits(const ModelConfig& policy, const ModelConfig& encoder,
                      const char* who);

/// Emits `def encode_rgb(self, rgb) -> Tensor`: uint8 [B, H, W, 3] ->
/// features [B, C, h, w], as RgbEncoderImpl::forward(); its tensors are
/// registered under "encoder.rgb.cnn".
void emitRgbEncoder(ScriptWriter& w, RgbEncoderImpl& rgb);

/// Emits `def encode_depth(self, depth) -> Tensor`: float [B, H, W, 1] ->
/// features [B, C, h, w], as DepthEncoderImpl::forward(); tensors under
/// "encoder.depth.cnn".
void emitDepthEncoder(ScriptWriter& w, DepthEncoderImpl& depth);

/// Emits `def encode_instruction(self, tokens) -> (states, mask, last)` as
/// InstructionEncoderImpl::forward() for `config` (tokens int64 [B, L] or,
/// with rxr_text, features [B, L, D]; bidirectional for CMA): a masked
/// (Bi)LSTM, identical to the packed one at every real token; trailing
/// padding columns are dropped first. Tensors under `prefix`
/// ("policy.instruction_encoder").
void emitInstructionEncoder(ScriptWriter& w, const ModelConfig& config,
                            const std::string& prefix);

/// The expression of one step of the MaskedGru registered under `prefix`:
/// `torch.gru_cell(input, state * mask, ...)`, where `mask` names a [B, 1]
/// float variable, 0 at an episode's first step (the state's reset).
std::string gruStep(const ScriptWriter& w, const std::string& prefix,
                    const std::string& input, const std::string& state,
                    const std::string& mask);

/// The expression `torch.linear(input, weight, bias)` of the Linear
/// registered under `prefix`.
std::string linear(const ScriptWriter& w, const std::string& prefix,
                   const std::string& input);

}  // namespace vln::models
