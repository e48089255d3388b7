#pragma once
// Configuration of the navigation models (YAML section `model:`). Defaults
// reproduce VLN-CE's published sizes (vlnce_baselines/config/default.py and
// the paper configs seq2seq.yaml / cma.yaml), so a config that only sets
// `policy` is a paper-scale model. LibTorch stays out of this header so that
// configs of other modules can embed ModelConfig cheaply.

#include <array>
#include <cstdint>
#include <string>

#include "common/Config.h"

namespace vln::models {

/// The two agents of the paper (Section 4).
enum class PolicyType { kSeq2Seq, kCma };

/// Visual encoder architectures. For RGB, resnet50/resnet18 are torchvision's
/// ImageNet networks (BatchNorm); for depth they are DD-PPO's GroupNorm
/// ResNets (habitat_baselines resnet.py) followed by the compression conv.
/// small_cnn is a three-layer CNN for fast CPU runs.
enum class EncoderType { kResNet50, kResNet18, kSmallCnn };

/// Number of actions: STOP, MOVE_FORWARD, TURN_LEFT, TURN_RIGHT (Habitat ids).
inline constexpr int64_t kNumActions = 4;

/// Shape of one observation's feature map, [channels, height, width].
using FeatureShape = std::array<int64_t, 3>;

/// Everything that defines a model's architecture and where its pretrained
/// encoder weights come from.
struct ModelConfig {
  /// Agent architecture.
  PolicyType policy = PolicyType::kCma;
  /// RGB encoder architecture.
  EncoderType rgb_encoder = EncoderType::kResNet50;
  /// Depth encoder architecture.
  EncoderType depth_encoder = EncoderType::kResNet50;
  /// TorchScript file holding the RGB encoder's tensors by name (see
  /// scripts/convert_torchvision_resnet50.py); empty = random init.
  std::string rgb_weights;
  /// TorchScript file holding the depth encoder's tensors by name (see
  /// scripts/convert_ddppo_depth.py); empty = random init.
  std::string depth_weights;
  /// Train the RGB CNN (features cannot then be cached).
  bool rgb_trainable = false;
  /// Train the depth CNN (features cannot then be cached).
  bool depth_trainable = false;

  /// Ablations: the input is removed from the network, not zeroed. No vision
  /// is no_rgb + no_depth.
  bool no_rgb = false;
  bool no_depth = false;
  bool no_instruction = false;

  /// Instruction vocabulary size (R2R_VLNCE v1-3: 2504), PAD = token 0.
  int vocab_size = 2504;
  /// Word embedding width (GloVe 50-d).
  int embedding_dim = 50;
  /// Train the word embeddings (VLN-CE keeps GloVe frozen).
  bool fine_tune_embeddings = false;
  /// Instruction LSTM hidden size per direction (CMA is bidirectional, so
  /// its instruction states are twice this wide).
  int instruction_hidden_size = 128;
  /// Hidden size of the state GRU(s).
  int hidden_size = 512;
  /// Width of the learned previous-action embedding (CMA; Seq2Seq only
  /// when seq2seq_prev_action).
  int prev_action_embedding_dim = 32;
  /// Seq2Seq also feeds the previous-action embedding (VLN-CE
  /// SEQ2SEQ.use_prev_action, off in the paper).
  bool seq2seq_prev_action = false;
  /// Width of the RGB projection (and CMA's attended RGB value).
  int rgb_projection_size = 256;
  /// Width of the depth projection (and CMA's attended depth value).
  int depth_projection_size = 128;
  /// Width of CMA's learned per-position embedding appended to each visual
  /// feature-map location.
  int spatial_embedding_dim = 64;
  /// Adds the progress-monitor head (tanh of a linear map of the action
  /// GRU state).
  bool progress_monitor = false;
  /// Base width of DD-PPO's depth ResNet (ngroups = half of it).
  int depth_resnet_base_planes = 32;

  /// RGB observation size, pixels.
  int rgb_height = 224;
  int rgb_width = 224;
  /// Depth observation size, pixels.
  int depth_height = 256;
  int depth_width = 256;

  /// Torch device string: "cpu", "cuda", "cuda:1", ...
  std::string device = "cpu";

  void visit(common::ConfigVisitor& v) {
    v.enumeration(
        "policy", policy,
        {{"seq2seq", PolicyType::kSeq2Seq}, {"cma", PolicyType::kCma}},
        "Agent architecture (paper Section 4)");
    const std::initializer_list<std::pair<const char*, EncoderType>> encoders =
        {{"resnet50", EncoderType::kResNet50},
         {"resnet18", EncoderType::kResNet18},
         {"small_cnn", EncoderType::kSmallCnn}};
    v.enumeration("rgb_encoder", rgb_encoder, encoders,
                  "RGB CNN (torchvision ResNet or small CNN)");
    v.enumeration("depth_encoder", depth_encoder, encoders,
                  "Depth CNN (DD-PPO GroupNorm ResNet or small CNN)");
    v.field("rgb_weights", rgb_weights,
            "TorchScript file with RGB encoder weights (empty: random)");
    v.field("depth_weights", depth_weights,
            "TorchScript file with depth encoder weights (empty: random)");
    v.field("rgb_trainable", rgb_trainable, "Train the RGB CNN");
    v.field("depth_trainable", depth_trainable, "Train the depth CNN");
    v.field("no_rgb", no_rgb, "Ablation: remove the RGB input");
    v.field("no_depth", no_depth, "Ablation: remove the depth input");
    v.field("no_instruction", no_instruction,
            "Ablation: remove the instruction input");
    v.field("vocab_size", vocab_size, "Instruction vocabulary size",
            common::atLeast(2));
    v.field("embedding_dim", embedding_dim, "Word embedding width",
            common::atLeast(1));
    v.field("fine_tune_embeddings", fine_tune_embeddings,
            "Train the word embeddings");
    v.field("instruction_hidden_size", instruction_hidden_size,
            "Instruction LSTM hidden size per direction", common::atLeast(1));
    v.field("hidden_size", hidden_size, "State GRU hidden size",
            common::atLeast(2));
    v.field("prev_action_embedding_dim", prev_action_embedding_dim,
            "Previous-action embedding width", common::atLeast(1));
    v.field("seq2seq_prev_action", seq2seq_prev_action,
            "Seq2Seq also receives the previous action");
    v.field("rgb_projection_size", rgb_projection_size, "RGB projection width",
            common::atLeast(1));
    v.field("depth_projection_size", depth_projection_size,
            "Depth projection width", common::atLeast(1));
    v.field("spatial_embedding_dim", spatial_embedding_dim,
            "CMA per-position embedding width", common::atLeast(1));
    v.field("progress_monitor", progress_monitor, "Add the progress head");
    v.field("depth_resnet_base_planes", depth_resnet_base_planes,
            "DD-PPO depth ResNet base width (even)", common::atLeast(2));
    v.field("rgb_height", rgb_height, "RGB image height (px)",
            common::inRange(8, 4096));
    v.field("rgb_width", rgb_width, "RGB image width (px)",
            common::inRange(8, 4096));
    v.field("depth_height", depth_height, "Depth image height (px)",
            common::inRange(8, 4096));
    v.field("depth_width", depth_width, "Depth image width (px)",
            common::inRange(8, 4096));
    v.field("device", device, "Torch device (cpu, cuda, cuda:N)");
  }
  bool operator==(const ModelConfig&) const = default;

  /// Throws std::invalid_argument naming the field and value for settings
  /// that cannot build a network (a depth ResNet on images smaller than
  /// 64 px, an odd ResNet base width, an unparsable device, ...).
  void validate() const;

  /// True when the network reads RGB features.
  bool usesRgb() const { return !no_rgb; }
  /// True when the network reads depth features.
  bool usesDepth() const { return !no_depth; }
  /// True when the network reads the instruction.
  bool usesInstruction() const { return !no_instruction; }
  /// Width of one instruction state: hidden * 2 for CMA (BiLSTM).
  int instructionStateSize() const {
    return policy == PolicyType::kCma ? 2 * instruction_hidden_size
                                      : instruction_hidden_size;
  }
  /// Number of stacked recurrent states: 1 (Seq2Seq) or 2 (CMA).
  int numRecurrentLayers() const { return policy == PolicyType::kCma ? 2 : 1; }
};

/// Shape [C, h, w] of the RGB encoder's output for `config`'s RGB image size:
/// resnet50 [2048,4,4], resnet18 [512,4,4] (adaptive-pooled to 4x4 as in
/// VLN-CE, whatever the input size), small_cnn [64,4,4].
FeatureShape rgbFeatureShape(const ModelConfig& config);

/// Shape [C, h, w] of the depth encoder's output for `config`'s depth image
/// size. DD-PPO ResNets (input average-pooled 2x, backbone stride 32, then a
/// compression conv to about 2048 values): 256x256 -> [128,4,4],
/// 128x128 -> [512,2,2], 64x64 -> [2048,1,1]. small_cnn: [32,4,4].
FeatureShape depthFeatureShape(const ModelConfig& config);

/// Short name of a policy type as spelled in YAML ("seq2seq", "cma").
const char* policyName(PolicyType type);
/// Short name of an encoder type as spelled in YAML.
const char* encoderName(EncoderType type);

}  // namespace vln::models
