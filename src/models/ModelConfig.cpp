#include "models/ModelConfig.h"

#include <cmath>

#include "common/Check.h"

namespace vln::models {
namespace {

// output size of a convolution or pooling window along one axis
int64_t convOut(int64_t in, int64_t kernel, int64_t stride, int64_t padding) {
  return (in + 2 * padding - kernel) / stride + 1;
}

// DD-PPO's ResNet (habitat_baselines resnet.py): 7x7/2 stem, 3x3/2 max pool,
// then three stride-2 stages; returns the backbone's output size along an
// axis of `in` pixels after ResNetEncoder's 2x average pool
int64_t ddppoSpatial(int64_t in) {
  int64_t x = in / 2;
  x = convOut(x, 7, 2, 3);
  x = convOut(x, 3, 2, 1);
  for (int stage = 0; stage < 3; ++stage) x = convOut(x, 3, 2, 1);
  return x;
}

// ResNetEncoder sizes its compression conv from the image height alone:
// final_spatial = int((height // 2) / 32), channels = round(2048 / s^2)
int64_t ddppoCompressionChannels(int64_t height) {
  const int64_t finalSpatial = (height / 2) / 32;
  VLN_ASSERT(finalSpatial >= 1);
  return std::llround(2048.0 /
                      static_cast<double>(finalSpatial * finalSpatial));
}

}  // namespace

void ModelConfig::validate() const {
  VLN_CHECK_ARG(!(no_rgb && no_depth && no_instruction),
                "ModelConfig::validate(): model.no_rgb, model.no_depth and "
                "model.no_instruction are all true, the policy has no input");
  VLN_CHECK_ARG(rgb_semantic_outputs == 0 || !rgb_trainable,
                "ModelConfig::validate(): model.rgb_semantic_outputs reads "
                "frozen pretrained heads, and model.rgb_trainable is true");
  VLN_CHECK_ARG(!leg_attention || !no_instruction,
                "ModelConfig::validate(): model.leg_attention attends to the "
                "instruction, and model.no_instruction is true");
  VLN_CHECK_ARG(!candidate_text || !no_instruction,
                "ModelConfig::validate(): model.candidate_text attends to the "
                "instruction, and model.no_instruction is true");
  VLN_CHECK_ARG(!clause_tracker || !no_instruction,
                "ModelConfig::validate(): model.clause_tracker follows the "
                "instruction, and model.no_instruction is true");
  VLN_CHECK_ARG(
      !goal_match || (!no_instruction && !no_rgb && rgb_semantic_outputs > 0),
      "ModelConfig::validate(): model.goal_match matches the "
      "semantic heads' labels (model.rgb_semantic_outputs, got ",
      rgb_semantic_outputs, ") with the instruction's, and needs both (no_rgb ",
      no_rgb, ", no_instruction ", no_instruction, ")");
  VLN_CHECK_ARG(!rgb_cnn_channels.empty() &&
                    rgb_cnn_channels.size() == rgb_cnn_strides.size(),
                "ModelConfig::validate(): model.rgb_cnn_channels (",
                rgb_cnn_channels.size(), " layers) and model.rgb_cnn_strides (",
                rgb_cnn_strides.size(),
                ") must name the same number of layers, at least one");
  VLN_CHECK_ARG(rgb_encoder == EncoderType::kSmallCnn ||
                    (rgb_cnn_channels == kSmallCnnRgbChannels &&
                     rgb_cnn_strides == kSmallCnnStrides),
                "ModelConfig::validate(): model.rgb_cnn_channels and "
                "model.rgb_cnn_strides shape the small_cnn RGB encoder, and "
                "model.rgb_encoder is '",
                encoderName(rgb_encoder), "'");
  VLN_CHECK_ARG(!clause_tracker_memory || clause_tracker,
                "ModelConfig::validate(): model.clause_tracker_memory is a "
                "part of model.clause_tracker, which is false");
  if (usesDepth() && depth_encoder != EncoderType::kSmallCnn) {
    VLN_CHECK_ARG(depth_height >= 64 && depth_width >= 64,
                  "ModelConfig::validate(): model.depth_encoder '",
                  encoderName(depth_encoder),
                  "' (DD-PPO ResNet, stride 64 with its input pooling) needs "
                  "depth images of at least 64x64, got model.depth_height=",
                  depth_height, " model.depth_width=", depth_width);
    VLN_CHECK_ARG(depth_resnet_base_planes % 2 == 0,
                  "ModelConfig::validate(): model.depth_resnet_base_planes "
                  "must be even (GroupNorm groups = base / 2), got ",
                  depth_resnet_base_planes);
  }
  VLN_CHECK_ARG(num_actions == kNumActions || num_actions == kNumLookActions,
                "ModelConfig::validate(): model.num_actions must be ",
                kNumActions, " (R2R_VLNCE) or ", kNumLookActions,
                " (RxR_VLNCE, with LOOK_UP and LOOK_DOWN), got ", num_actions);
  VLN_CHECK_ARG(turn_count_embedding_dim == 0 || policy == PolicyType::kCma,
                "ModelConfig::validate(): model.turn_count_embedding_dim needs "
                "model.policy cma, got policy ",
                policyName(policy), " with turn_count_embedding_dim ",
                turn_count_embedding_dim);
  VLN_CHECK_ARG(hidden_size % 2 == 0,
                "ModelConfig::validate(): model.hidden_size must be even (CMA "
                "attention keys are hidden_size / 2 wide), got ",
                hidden_size);
  VLN_CHECK_ARG(
      device == "cpu" || device == "cuda" || device.rfind("cuda:", 0) == 0,
      "ModelConfig::validate(): model.device must be cpu, cuda or cuda:N, "
      "got '",
      device, "'");
  if (device.rfind("cuda:", 0) == 0) {
    const std::string index = device.substr(5);
    VLN_CHECK_ARG(!index.empty() && index.find_first_not_of("0123456789") ==
                                        std::string::npos,
                  "ModelConfig::validate(): model.device has a bad CUDA "
                  "index, got '",
                  device, "'");
  }
}

FeatureShape rgbFeatureShape(const ModelConfig& config) {
  if (config.rgb_semantic_outputs > 0)
    return {config.rgb_semantic_outputs, 1, 1};
  switch (config.rgb_encoder) {
    case EncoderType::kResNet50:
      return {2048, 4, 4};
    case EncoderType::kResNet18:
      return {512, 4, 4};
    case EncoderType::kSmallCnn:
      return {config.rgb_cnn_channels.back(), 4, 4};
  }
  VLN_ASSERT(false);
  return {};
}

FeatureShape depthFeatureShape(const ModelConfig& config) {
  if (config.depth_encoder == EncoderType::kSmallCnn)
    return {kSmallCnnDepthChannels.back(), 4, 4};
  VLN_CHECK_ARG(config.depth_height >= 64 && config.depth_width >= 64,
                "depthFeatureShape(): DD-PPO ResNet needs depth images of at "
                "least 64x64, got ",
                config.depth_height, "x", config.depth_width);
  return {ddppoCompressionChannels(config.depth_height),
          ddppoSpatial(config.depth_height), ddppoSpatial(config.depth_width)};
}

}  // namespace vln::models
