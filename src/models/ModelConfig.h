#pragma once
// Configuration of the navigation models (YAML section `model:`). Defaults
// reproduce VLN-CE's published sizes (vlnce_baselines/config/default.py and
// the paper configs seq2seq.yaml / cma.yaml), so a config that only sets
// `policy` is a paper-scale model. LibTorch stays out of this header so that
// configs of other modules can embed ModelConfig cheaply.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "common/Config.h"

namespace vln::models {

/// The two agents of the paper (Section 4).
enum class PolicyType { kSeq2Seq, kCma };

/// What the instruction encoder reads: token ids through a word embedding
/// (R2R_VLNCE, GloVe), or precomputed per-token text features (RxR_VLNCE's
/// BERT features, VLN-CE's INSTRUCTION_ENCODER.sensor_uuid: rxr_instruction),
/// fed to the same (Bi)LSTM without an embedding layer.
enum class InstructionFeatures { kTokens, kRxrText };

/// Visual encoder architectures. For RGB, resnet50/resnet18 are torchvision's
/// ImageNet networks (BatchNorm); for depth they are DD-PPO's GroupNorm
/// ResNets (habitat_baselines resnet.py) followed by the compression conv.
/// small_cnn is a three-layer CNN for fast CPU runs.
enum class EncoderType { kResNet50, kResNet18, kSmallCnn };

/// Where a token model's word embeddings start: the dataset's GloVe
/// (VLN-CE) or random vectors (randomWordEmbeddings() in
/// InstructionEncoder.h). Our GloVe is fitted on the world's templated
/// instructions and gives words that share every context nearly the same
/// vector (left/right: cosine 0.997), which training must first pull apart.
enum class WordEmbeddings { kGlove, kRandom };

/// YAML names of the policy types (policyName()).
inline constexpr common::EnumNames<PolicyType, 2> kPolicyNames = {
    {{"seq2seq", PolicyType::kSeq2Seq}, {"cma", PolicyType::kCma}}};
/// YAML names of the instruction inputs (instructionFeaturesName()).
inline constexpr common::EnumNames<InstructionFeatures, 2>
    kInstructionFeaturesNames = {{{"tokens", InstructionFeatures::kTokens},
                                  {"rxr_text", InstructionFeatures::kRxrText}}};
/// YAML names of the word-embedding initialisations.
inline constexpr common::EnumNames<WordEmbeddings, 2> kWordEmbeddingsNames = {
    {{"glove", WordEmbeddings::kGlove}, {"random", WordEmbeddings::kRandom}}};
/// YAML names of the encoder types (encoderName()).
inline constexpr common::EnumNames<EncoderType, 3> kEncoderNames = {
    {{"resnet50", EncoderType::kResNet50},
     {"resnet18", EncoderType::kResNet18},
     {"small_cnn", EncoderType::kSmallCnn}}};

/// Default number of actions (model.num_actions), R2R_VLNCE's: STOP,
/// MOVE_FORWARD, TURN_LEFT, TURN_RIGHT (Habitat ids 0..3).
inline constexpr int64_t kNumActions = 4;
/// RxR_VLNCE's number of actions: those four, LOOK_UP (4) and LOOK_DOWN (5).
inline constexpr int64_t kNumLookActions = 6;
/// The action ids the turn count reads (sim::Action's, Habitat's).
inline constexpr int64_t kMoveForwardAction = 1;
inline constexpr int64_t kTurnLeftAction = 2;
inline constexpr int64_t kTurnRightAction = 3;
/// The turn count (model.turn_count_embedding_dim) saturates at this many
/// turns either way: 180 degrees at VLN-CE's 15-degree turns.
inline constexpr int64_t kMaxTurnCount = 12;

/// The small CNN's layers (model.rgb_cnn_channels and rgb_cnn_strides): the
/// RGB encoder's by default; the depth encoder's end on 32 channels.
inline const std::vector<int> kSmallCnnRgbChannels = {32, 64, 64};
inline const std::vector<int> kSmallCnnDepthChannels = {32, 64, 32};
inline const std::vector<int> kSmallCnnStrides = {2, 2, 2};

/// Shape of one observation's feature map, [channels, height, width].
using FeatureShape = std::array<int64_t, 3>;

/// Everything that defines a model's architecture and where its pretrained
/// encoder weights come from.
struct ModelConfig {
  PolicyType policy = PolicyType::kCma;
  EncoderType rgb_encoder = EncoderType::kResNet50;
  EncoderType depth_encoder = EncoderType::kResNet50;
  std::vector<int> rgb_cnn_channels = kSmallCnnRgbChannels;
  std::vector<int> rgb_cnn_strides = kSmallCnnStrides;
  std::string rgb_weights;
  std::string depth_weights;
  int rgb_semantic_outputs = 0;
  bool rgb_trainable = false;
  bool rgb_batch_statistics = false;
  bool normalize_rgb = true;
  bool depth_trainable = false;
  bool no_rgb = false;
  bool no_depth = false;
  bool no_instruction = false;
  int num_actions = static_cast<int>(kNumActions);
  InstructionFeatures instruction_features = InstructionFeatures::kTokens;
  int text_feature_dim = 768;
  int vocab_size = 2504;
  int embedding_dim = 50;
  bool fine_tune_embeddings = false;
  WordEmbeddings word_embeddings = WordEmbeddings::kGlove;
  int instruction_hidden_size = 128;
  int hidden_size = 512;
  int prev_action_embedding_dim = 32;
  bool seq2seq_prev_action = false;
  int turn_count_embedding_dim = 0;
  int rgb_projection_size = 256;
  int depth_projection_size = 128;
  int spatial_embedding_dim = 64;
  bool progress_monitor = false;
  int heading_harmonics = 1;
  bool leg_attention = false;
  bool candidate_text = false;
  bool clause_tracker = false;
  int clause_window = 2;
  bool clause_tracker_memory = false;
  bool goal_match = false;
  double dropout = 0.0;
  int depth_resnet_base_planes = 32;
  int rgb_height = 224;
  int rgb_width = 224;
  int depth_height = 256;
  int depth_width = 256;
  std::string device = "cpu";

  void visit(common::ConfigVisitor& v) {
    v.enumeration("policy", policy, kPolicyNames,
                  "Agent architecture (paper Section 4)");
    v.enumeration("rgb_encoder", rgb_encoder, kEncoderNames,
                  "RGB CNN (torchvision ResNet or small CNN)");
    v.enumeration("depth_encoder", depth_encoder, kEncoderNames,
                  "Depth CNN (DD-PPO GroupNorm ResNet or small CNN)");
    v.field("rgb_cnn_channels", rgb_cnn_channels,
            "small_cnn RGB encoder only: the output channels of its 3x3 "
            "convolutions (ReLU after each), in order; the last is the "
            "feature map's depth. The default [32, 64, 64] is the small CNN "
            "of the CPU main job",
            common::inRange(1, 1024));
    v.field("rgb_cnn_strides", rgb_cnn_strides,
            "small_cnn RGB encoder only: the stride (1 or 2) of each of "
            "model.rgb_cnn_channels' convolutions",
            common::inRange(1, 2));
    v.field("rgb_weights", rgb_weights,
            "TorchScript file holding the RGB encoder's tensors by name, as "
            "scripts/convert_torchvision_resnet50.py writes (empty: random "
            "init)");
    v.field("rgb_semantic_outputs", rgb_semantic_outputs,
            "Waypoint CMA only: 0 (the default) gives the policy the RGB "
            "CNN's feature map; N > 0 gives it, per image, the sigmoid of the "
            "N outputs of an rgb_semantic pretraining's heads (object "
            "categories, colours, room type: 29 + 12 + 9 = 50 for the "
            "default world), and model.rgb_weights must then name that "
            "pretraining's semantic_net.pt (docs/pretraining.md)",
            common::inRange(0, 4096));
    v.field("depth_weights", depth_weights,
            "TorchScript file holding the depth encoder's tensors by name, as "
            "scripts/convert_ddppo_depth.py writes (empty: random init)");
    v.field("rgb_trainable", rgb_trainable,
            "Train the RGB CNN (its features cannot then be cached)");
    v.field("rgb_batch_statistics", rgb_batch_statistics,
            "While collecting training data, normalise the frozen RGB "
            "ResNet's BatchNorm by the statistics of the batch being encoded, "
            "as VLN-CE does (its Net calls self.train(), so the ResNet runs "
            "in train mode during collection): stored features then depend on "
            "the observations encoded together (trainer.num_envs, one with "
            "exact_resume). The running (ImageNet) statistics are not updated "
            "and evaluation always uses them (docs/models.md). No effect on "
            "small_cnn, which has no BatchNorm");
    v.field("normalize_rgb", normalize_rgb,
            "Normalise RGB pixels with the ImageNet mean and std after "
            "scaling them to [0, 1], as torchvision's weights expect (false: "
            "only divide by 255, as VLN-CE's TorchVisionResNet50 does with "
            "its default MODEL.normalize_rgb: False; "
            "scripts/convert_vlnce_checkpoint.py writes false)");
    v.field("depth_trainable", depth_trainable,
            "Train the depth CNN (its features cannot then be cached)");
    v.field("no_rgb", no_rgb,
            "Ablation: remove the RGB input from the network, not zero it "
            "(no vision: no_rgb and no_depth)");
    v.field("no_depth", no_depth,
            "Ablation: remove the depth input from the network, not zero it");
    v.field("no_instruction", no_instruction,
            "Ablation: remove the instruction input from the network, not "
            "zero it");
    v.field("num_actions", num_actions,
            "Action logits and previous-action embedding size (plus one "
            "start entry): 4 for R2R_VLNCE, 6 for RxR_VLNCE (LOOK_UP, "
            "LOOK_DOWN; needs sim.agent.look_actions)",
            common::inRange(4, 6));
    v.enumeration("instruction_features", instruction_features,
                  kInstructionFeaturesNames,
                  "Instruction input: tokens (word ids through the "
                  "embedding) or rxr_text (precomputed [L, "
                  "text_feature_dim] features, zero rows = padding; RxR)");
    v.field("text_feature_dim", text_feature_dim,
            "Width of a text feature row with instruction_features: rxr_text "
            "(RxR's BERT features: 768)",
            common::atLeast(1));
    v.field("vocab_size", vocab_size,
            "Instruction vocabulary size, PAD = token 0 (R2R_VLNCE v1-3: 2504)",
            common::atLeast(2));
    v.field("embedding_dim", embedding_dim, "Word embedding width (GloVe: 50)",
            common::atLeast(1));
    v.field("fine_tune_embeddings", fine_tune_embeddings,
            "Train the word embeddings (VLN-CE keeps GloVe frozen)");
    v.enumeration("word_embeddings", word_embeddings, kWordEmbeddingsNames,
                  "Initial word embeddings of a token model: glove (the "
                  "dataset's embeddings file, VLN-CE) or random (N(0, 1) "
                  "drawn from trainer.seed, PAD zero; no file read)");
    v.field("instruction_hidden_size", instruction_hidden_size,
            "Instruction LSTM hidden size per direction (CMA is bidirectional, "
            "so its instruction states are twice this wide)",
            common::atLeast(1));
    v.field("hidden_size", hidden_size, "Hidden size of the state GRU(s)",
            common::atLeast(2));
    v.field("prev_action_embedding_dim", prev_action_embedding_dim,
            "Width of the learned previous-action embedding (CMA; Seq2Seq only "
            "with seq2seq_prev_action)",
            common::atLeast(1));
    v.field("seq2seq_prev_action", seq2seq_prev_action,
            "Seq2Seq also receives the previous-action embedding (VLN-CE "
            "SEQ2SEQ.use_prev_action, off in the paper)");
    v.field("turn_count_embedding_dim", turn_count_embedding_dim,
            "CMA only; 0: off. Width of a learned embedding of the net number "
            "of turns since the last MOVE_FORWARD (TURN_LEFT +1, TURN_RIGHT "
            "-1, clamped to +-kMaxTurnCount), fed to both GRUs beside the "
            "previous action. The count is a function of the agent's own "
            "actions, carried as a third row of the recurrent state; it lets "
            "the agent turn by the amount the words ask",
            common::atLeast(0));
    v.field("rgb_projection_size", rgb_projection_size,
            "Width of the RGB projection (and of CMA's attended RGB value)",
            common::atLeast(1));
    v.field("depth_projection_size", depth_projection_size,
            "Width of the depth projection (and of CMA's attended depth value)",
            common::atLeast(1));
    v.field("spatial_embedding_dim", spatial_embedding_dim,
            "Width of CMA's learned per-position embedding appended to each "
            "visual feature-map location",
            common::atLeast(1));
    v.field("progress_monitor", progress_monitor,
            "Add the progress-monitor head (tanh of a linear map of the action "
            "GRU state)");
    v.field("heading_harmonics", heading_harmonics,
            "Waypoint CMA only: a heading (a view's, a candidate's, the "
            "previous decision's) enters the policy as sin and cos of m times "
            "it for m = 1 .. this (1: the heading's sin and cos alone, as "
            "always; 4 measured and not adopted, docs/results.md)",
            common::inRange(1, 16));
    v.field("leg_attention", leg_attention,
            "Waypoint CMA only: a second attention over the instruction, "
            "queried from the first GRU's state, whose attended words join "
            "the second GRU's input and the candidates' query; "
            "waypoint_agent.sub_instruction_weight then supervises this "
            "attention and leaves the first free (measured so and not "
            "adopted, docs/results.md)");
    v.field("candidate_text", candidate_text,
            "Waypoint CMA only: each candidate attends over the instruction "
            "with its own key (its view and heading) and the words it finds "
            "are added to its key, so a candidate can match the words that "
            "describe it (a landmark in its view, a turn towards its "
            "heading) whichever words the state attends to (measured and "
            "not adopted, docs/results.md)");
    v.field("clause_tracker", clause_tracker,
            "Waypoint CMA only: the instruction is cut into clauses by a "
            "rule (data::ruleClauses()), a pointer moves along them (at "
            "each decision a head on the first GRU's state chooses to stay "
            "or to advance one or two clauses, never back) and the "
            "decision's attention reads only the words of clause_window "
            "clauses from the pointer on; the head is trained towards the "
            "clauses of the reference path's leg ahead "
            "(waypoint_agent.clause_tracker_weight)");
    v.field("clause_window", clause_window,
            "With clause_tracker: how many clauses from the pointer on a "
            "decision reads",
            common::inRange(1, 16));
    v.field("clause_tracker_memory", clause_tracker_memory,
            "With clause_tracker: the head also reads the second GRU's state "
            "after the previous decision, which has read the words the "
            "previous pointer chose (training then runs an episode's "
            "decisions one at a time)");
    v.field("goal_match", goal_match,
            "Waypoint CMA only: the RGB features are the semantic heads' "
            "label probabilities (rgb_semantic_outputs, or the views' true "
            "labels with waypoint_agent.view_labels), and they reach the "
            "policy only as their match with the labels the instruction's "
            "goal clause names (world::goalLabels()): per view the highest "
            "probability of a named category, colour and room, beside the "
            "depth features, and their highest over the views in the STOP "
            "key");
    v.field("dropout", dropout,
            "Dropout probability while training (0: none; VLN-CE has none): "
            "on the instruction's encoded states, on the visual feature maps "
            "and on the state the action head reads, as R2R agents regularise "
            "(EnvDrop's feature and hidden dropout). Collection and "
            "evaluation run without it",
            common::inRange(0.0, 0.9));
    v.field("depth_resnet_base_planes", depth_resnet_base_planes,
            "Base width of DD-PPO's depth ResNet (even: GroupNorm groups are "
            "half of it)",
            common::atLeast(2));
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
  /// True when the instruction arrives as float text features [B, L, D]
  /// (instruction_features: rxr_text) instead of token ids.
  bool usesTextFeatures() const {
    return instruction_features == InstructionFeatures::kRxrText;
  }
  /// Width of the instruction LSTM's input: embedding_dim for tokens,
  /// text_feature_dim for text features.
  int instructionInputSize() const {
    return usesTextFeatures() ? text_feature_dim : embedding_dim;
  }
  /// Width of one instruction state: hidden * 2 for CMA (BiLSTM).
  int instructionStateSize() const {
    return policy == PolicyType::kCma ? 2 * instruction_hidden_size
                                      : instruction_hidden_size;
  }
  /// True when the CMA reads its turn count (turn_count_embedding_dim).
  bool countsTurns() const {
    return policy == PolicyType::kCma && turn_count_embedding_dim > 0;
  }
  /// Rows of the recurrent state [rows, hidden_size]: 1 (Seq2Seq's GRU),
  /// 2 (CMA's two GRUs), 3 (CMA with the turn count in row 2, column 0).
  int recurrentStateRows() const {
    if (policy != PolicyType::kCma) return 1;
    return countsTurns() ? 3 : 2;
  }
};

/// Shape [C, h, w] of the RGB encoder's output for `config`'s RGB image size:
/// resnet50 [2048,4,4], resnet18 [512,4,4] (adaptive-pooled to 4x4 as in
/// VLN-CE, whatever the input size), small_cnn [64,4,4]; with
/// model.rgb_semantic_outputs N > 0, [N, 1, 1] (the pretrained heads').
FeatureShape rgbFeatureShape(const ModelConfig& config);

/// Shape [C, h, w] of the depth encoder's output for `config`'s depth image
/// size. DD-PPO ResNets (input average-pooled 2x, backbone stride 32, then a
/// compression conv to about 2048 values): 256x256 -> [128,4,4],
/// 128x128 -> [512,2,2], 64x64 -> [2048,1,1]. small_cnn: [32,4,4].
FeatureShape depthFeatureShape(const ModelConfig& config);

/// Short name of a policy type as spelled in YAML ("seq2seq", "cma").
inline const char* policyName(PolicyType type) {
  return common::enumName(kPolicyNames, type);
}
/// Short name of an instruction input as spelled in YAML.
inline const char* instructionFeaturesName(InstructionFeatures type) {
  return common::enumName(kInstructionFeaturesNames, type);
}
/// Short name of an encoder type as spelled in YAML.
inline const char* encoderName(EncoderType type) {
  return common::enumName(kEncoderNames, type);
}

}  // namespace vln::models
