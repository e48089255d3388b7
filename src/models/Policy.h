#pragma once
// The policy networks of the paper (Section 4): they consume visual feature
// maps (from ObservationEncoder, possibly cached on disk), the encoded
// instruction and the previous action, and return action logits, the
// progress estimate and the new recurrent state.
//
// Two modes share one implementation:
//  - sequence mode (training): inputs [T, B, ...]; every non-recurrent layer
//    (projections, attention) runs over all T*B steps at once, only the GRU
//    recurrences loop over T, and the state is reset where not_done = 0;
//  - step mode (acting): inputs [B, ...], one step, recurrent state in/out;
//    the instruction is encoded once per episode (encodeInstruction()) and
//    the result is passed to every step.
//
// Actions are Habitat's ids: 0 STOP, 1 MOVE_FORWARD, 2 TURN_LEFT,
// 3 TURN_RIGHT, and with model.num_actions 6 (RxR) 4 LOOK_UP, 5 LOOK_DOWN.
// The previous action enters as VLN-CE encodes it: embedding index
// (prev_action + 1) * not_done, so index 0 means "episode start".

#include <torch/torch.h>

#include <memory>

#include "models/InstructionEncoder.h"
#include "models/ModelConfig.h"

namespace vln::models {

/// The instruction of each batch row, encoded once per episode. Which
/// tensors are defined depends on the policy (undefined when
/// model.no_instruction).
struct EncodedInstruction {
  torch::Tensor states;   ///< CMA: [B, L, 2 * instruction_hidden] float
  torch::Tensor keys;     ///< CMA: [B, L, hidden_size / 2] attention keys
  torch::Tensor mask;     ///< CMA: [B, L] bool, true at real tokens
  torch::Tensor summary;  ///< Seq2Seq: [B, instruction_hidden] final state

  /// The rows `rows` (int64 [B'] on the tensors' device) of every defined
  /// tensor, e.g. to drop paused environments.
  EncodedInstruction select(const torch::Tensor& rows) const;
};

/// Per-step inputs. Sequence mode: leading dims [T, B]; step mode: [B].
struct PolicyInputs {
  torch::Tensor rgb;    ///< [.., C, h, w] float RGB features (rgbFeatureShape);
                        ///< may be undefined when model.no_rgb
  torch::Tensor depth;  ///< [.., C, h, w] float depth features
                        ///< (depthFeatureShape); undefined ok if no_depth
  torch::Tensor prev_actions;  ///< [..] int64 in [0, num_actions), the action
                               ///< taken before this step (any value where
                               ///< not_done = 0)
  torch::Tensor not_done;      ///< [..] float 0/1, 0 at an episode's first step
};

/// Policy outputs. Sequence mode: [T, B, ...]; step mode: [B, ...].
struct PolicyOutputs {
  torch::Tensor logits;    ///< [.., model.num_actions] action logits
                           ///< (unnormalised)
  torch::Tensor progress;  ///< [..] in (-1, 1); undefined unless
                           ///< model.progress_monitor
  torch::Tensor hidden;    ///< [B, recurrentStateRows, hidden_size] after the
                           ///< last step
  /// [.., B, L] the CMA's attention over the instruction's tokens (softmax
  /// weights, 0 on padding); undefined for policies that do not attend to
  /// the instruction (Seq2Seq, model.no_instruction).
  torch::Tensor instruction_attention;
};

/// Base of Seq2SeqPolicy and CmaPolicy (use makePolicy()).
class PolicyImpl : public torch::nn::Module {
 public:
  explicit PolicyImpl(const ModelConfig& config);
  ~PolicyImpl() override = default;

  /// Encodes the instruction: token ids int64 [B, L] (real tokens then
  /// PAD 0), or with model.instruction_features: rxr_text text features
  /// float [B, L, text_feature_dim] (real rows then zero rows). Returns an
  /// empty EncodedInstruction when model.no_instruction (the input may then
  /// be undefined).
  EncodedInstruction encodeInstruction(const torch::Tensor& instruction);

  /// Sequence mode: inputs [T, B, ...], hidden [B, layers, H] at t = 0
  /// (before the not_done[0] reset) -> outputs [T, B, ...].
  virtual PolicyOutputs forwardSequence(const EncodedInstruction& instruction,
                                        const PolicyInputs& inputs,
                                        const torch::Tensor& hidden) = 0;

  /// Step mode: inputs [B, ...] -> outputs [B, ...].
  PolicyOutputs step(const EncodedInstruction& instruction,
                     const PolicyInputs& inputs, const torch::Tensor& hidden);

  /// Zeros [batch, recurrentStateRows, hidden_size] on the policy's device.
  torch::Tensor initialHidden(int64_t batch) const;

  /// Copies a [vocab_size, embedding_dim] word-embedding matrix (GloVe) into
  /// the instruction encoder; no-op when model.no_instruction. Throws
  /// std::invalid_argument with text features (no embedding).
  void setWordEmbeddings(const torch::Tensor& matrix);

  const ModelConfig& config() const { return config_; }

  /// Undefined when model.no_instruction.
  InstructionEncoder instruction_encoder{nullptr};

 protected:
  /// Turns the encoder's output into what forwardSequence() reads.
  virtual EncodedInstruction prepareInstruction(
      const InstructionStates& states) = 0;
  /// Checks shapes of sequence-mode inputs; returns {T, B}.
  std::pair<int64_t, int64_t> checkInputs(const PolicyInputs& inputs,
                                          const torch::Tensor& hidden) const;
  /// Embedding indices (prev_action + 1) * not_done, int64 [T, B].
  static torch::Tensor prevActionIndex(const PolicyInputs& inputs);
  /// `x` with model.dropout applied in training mode; `x` itself in eval
  /// mode, with dropout 0 or when `x` is undefined.
  torch::Tensor trainingDropout(const torch::Tensor& x);
  /// Initialises an action head (orthogonal, gain 0.01, zero bias; habitat's
  /// CategoricalNet) and a progress head (Kaiming normal for tanh, zero
  /// bias; VLN-CE).
  static void initHeads(torch::nn::Linear& action, torch::nn::Linear* progress);

  ModelConfig config_;
  FeatureShape rgbShape_{};
  FeatureShape depthShape_{};
};

/// Builds the policy selected by config.policy, validated, on the CPU, with
/// `wordEmbeddings` ([vocab_size, embedding_dim]) copied in when defined.
std::shared_ptr<PolicyImpl> makePolicy(
    const ModelConfig& config, const torch::Tensor& wordEmbeddings = {});

/// The torch::Device named by config.device. Throws std::invalid_argument
/// naming model.device when it cannot be parsed.
torch::Device modelDevice(const ModelConfig& config);

/// `x` with dropout of probability `p` when `training`; `x` itself
/// otherwise, with p 0 or when `x` is undefined (model.dropout's rule for
/// every policy).
torch::Tensor dropoutWhileTraining(const torch::Tensor& x, double p,
                                   bool training);

}  // namespace vln::models
