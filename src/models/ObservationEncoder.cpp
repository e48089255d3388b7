#include "models/ObservationEncoder.h"

#include "common/Check.h"
#include "models/StateDict.h"

namespace vln::models {
namespace {

int resnetLayers(EncoderType type) {
  return type == EncoderType::kResNet50 ? 50 : 18;
}

// flattens leading dims of a channels-last image batch [..., H, W, C] into N
torch::Tensor flattenImages(const torch::Tensor& images, int64_t channels,
                            const char* who) {
  TORCH_CHECK(images.dim() >= 4 && images.size(-1) == channels, who,
              ": expected [..., H, W, ", channels, "], got ", images.sizes());
  return images.reshape({-1, images.size(-3), images.size(-2), channels});
}

// restores the leading dims of `images` on a [N, C, h, w] feature batch
torch::Tensor unflattenFeatures(const torch::Tensor& features,
                                const torch::Tensor& images) {
  std::vector<int64_t> shape(images.sizes().begin(), images.sizes().end() - 3);
  shape.insert(shape.end(), features.sizes().begin() + 1,
               features.sizes().end());
  return features.reshape(shape);
}

void freeze(torch::nn::Module& module) {
  for (auto& p : module.parameters()) p.set_requires_grad(false);
}

}  // namespace

// ===========================================================================
// RGB
// ===========================================================================

RgbEncoderImpl::RgbEncoderImpl(const ModelConfig& config)
    : normalize_(config.normalize_rgb) {
  // the CNN's own feature map, whatever the encoder outputs
  ModelConfig cnnConfig = config;
  cnnConfig.rgb_semantic_outputs = 0;
  const FeatureShape cnnShape = rgbFeatureShape(cnnConfig);
  if (config.rgb_encoder == EncoderType::kSmallCnn) {
    small = register_module(
        "cnn", SmallCnn(3, config.rgb_cnn_channels, config.rgb_cnn_strides));
  } else {
    resnet = register_module(
        "cnn", TorchVisionResNet(resnetLayers(config.rgb_encoder)));
  }
  if (config.rgb_semantic_outputs > 0)
    semantic = register_module(
        "semantic", torch::nn::Linear(cnnShape[0] * cnnShape[1] * cnnShape[2],
                                      config.rgb_semantic_outputs));
}

torch::Tensor RgbEncoderImpl::forward(const torch::Tensor& rgb) {
  TORCH_CHECK(rgb.scalar_type() == torch::kUInt8,
              "RgbEncoder::forward(): expected uint8 pixels, got ",
              rgb.scalar_type());
  const torch::Tensor images = flattenImages(rgb, 3, "RgbEncoder::forward()");
  const torch::Tensor x = images.permute({0, 3, 1, 2}).to(torch::kFloat32);
  torch::Tensor normalised;
  if (normalize_) {
    // ImageNet statistics (torchvision's documented normalisation), folded
    // into one multiply-add per pixel
    const auto opts = torch::TensorOptions().device(rgb.device());
    const torch::Tensor mean =
        torch::tensor({0.485f, 0.456f, 0.406f}, opts).view({1, 3, 1, 1});
    const torch::Tensor stdev =
        torch::tensor({0.229f, 0.224f, 0.225f}, opts).view({1, 3, 1, 1});
    normalised = x * (1.0f / 255.0f / stdev) - mean / stdev;
  } else {
    // VLN-CE's TorchVisionResNet: pixels / 255 only
    normalised = x / 255.0f;
  }
  torch::Tensor features;
  if (resnet) {
    features = torch::adaptive_avg_pool2d(resnet->forward(normalised), {4, 4});
  } else {
    features = small->forward(normalised);
  }
  if (semantic) {
    // what the pretraining's heads say the image shows, as probabilities
    const int64_t n = features.size(0);
    features = torch::sigmoid(semantic->forward(features.flatten(1)))
                   .view({n, -1, 1, 1});
  }
  return unflattenFeatures(features, rgb);
}

void RgbEncoderImpl::loadSemanticNet(const std::filesystem::path& file) {
  VLN_CHECK_ARG(semantic,
                "RgbEncoder::loadSemanticNet(): this encoder has "
                "no semantic heads (model.rgb_semantic_outputs is 0)");
  const NamedTensors all = readTensorFile(file);
  auto find = [&](const std::string& name) {
    for (const auto& [key, tensor] : all)
      if (key == name) return tensor;
    throw std::invalid_argument(strCat(
        "model.rgb_weights '", file.string(), "' has no tensor '", name,
        "': with model.rgb_semantic_outputs it must be the semantic_net.pt "
        "of an rgb_semantic pretraining (its CNN under rgb.cnn. and the "
        "heads categories, colors and room)"));
  };
  loadStateStrict(cnnModule(), stripPrefix(all, "rgb.cnn."), file.string());
  // the three heads as one linear layer, in the order the pretraining
  // declares them
  std::vector<torch::Tensor> weights, biases;
  for (const char* head : {"categories", "colors", "room"}) {
    weights.push_back(find(std::string(head) + ".weight"));
    biases.push_back(find(std::string(head) + ".bias"));
  }
  const torch::Tensor weight = torch::cat(weights, 0);
  VLN_CHECK_ARG(weight.size(0) == semantic->weight.size(0),
                "model.rgb_semantic_outputs is ", semantic->weight.size(0),
                " but the heads of '", file.string(), "' have ", weight.size(0),
                " outputs (categories ", weights[0].size(0), ", colours ",
                weights[1].size(0), ", rooms ", weights[2].size(0), ")");
  loadStateStrict(*semantic, {{"weight", weight}, {"bias", torch::cat(biases)}},
                  file.string());
}

torch::nn::Module& RgbEncoderImpl::cnnModule() {
  if (resnet) return *resnet;
  return *small;
}

// ===========================================================================
// depth
// ===========================================================================

DepthEncoderImpl::DepthEncoderImpl(const ModelConfig& config) {
  if (config.depth_encoder == EncoderType::kSmallCnn) {
    small = register_module(
        "cnn", SmallCnn(1, kSmallCnnDepthChannels, kSmallCnnStrides));
  } else {
    resnet = register_module(
        "cnn", DdppoResNetEncoder(resnetLayers(config.depth_encoder),
                                  config.depth_resnet_base_planes,
                                  config.depth_height));
  }
}

torch::Tensor DepthEncoderImpl::forward(const torch::Tensor& depth) {
  TORCH_CHECK(depth.is_floating_point(),
              "DepthEncoder::forward(): expected float depth, got ",
              depth.scalar_type());
  const torch::Tensor images =
      flattenImages(depth, 1, "DepthEncoder::forward()");
  const torch::Tensor x = images.permute({0, 3, 1, 2});
  const torch::Tensor features =
      resnet ? resnet->forward(x) : small->forward(x);
  return unflattenFeatures(features, depth);
}

torch::nn::Module& DepthEncoderImpl::cnnModule() {
  if (resnet) return *resnet;
  return *small;
}

// ===========================================================================
// both
// ===========================================================================

ObservationEncoderImpl::ObservationEncoderImpl(const ModelConfig& config)
    : config_(config) {
  config_.validate();
  if (config_.usesRgb()) {
    rgb = register_module("rgb", RgbEncoder(config_));
    if (!config_.rgb_trainable) freeze(*rgb);
  }
  if (config_.usesDepth()) {
    depth = register_module("depth", DepthEncoder(config_));
    if (!config_.depth_trainable) freeze(*depth);
  }
  train(true);
}

VisualFeatures ObservationEncoderImpl::forward(
    const torch::Tensor& rgbImages, const torch::Tensor& depthImages) {
  VisualFeatures out;
  if (rgb) {
    TORCH_CHECK(rgbImages.defined(),
                "ObservationEncoder::forward(): the model uses RGB but no RGB "
                "images were given");
    out.rgb = rgb->forward(rgbImages);
  }
  if (depth) {
    TORCH_CHECK(depthImages.defined(),
                "ObservationEncoder::forward(): the model uses depth but no "
                "depth images were given");
    out.depth = depth->forward(depthImages);
  }
  return out;
}

void ObservationEncoderImpl::loadPretrained() {
  if (rgb && rgb->semantic) {
    VLN_CHECK_ARG(!config_.rgb_weights.empty(),
                  "model.rgb_semantic_outputs is ",
                  config_.rgb_semantic_outputs,
                  " but model.rgb_weights is empty: it must name the "
                  "semantic_net.pt of an rgb_semantic pretraining");
    rgb->loadSemanticNet(config_.rgb_weights);
  } else if (rgb && !config_.rgb_weights.empty()) {
    loadModule(rgb->cnnModule(), config_.rgb_weights);
  }
  if (depth && !config_.depth_weights.empty())
    loadModule(depth->cnnModule(), config_.depth_weights);
}

void ObservationEncoderImpl::useRgbBatchStatistics(bool on) {
  if (!rgb) return;
  for (auto& module : rgb->cnnModule().modules(/*include_self=*/false)) {
    auto* bn = module->as<torch::nn::BatchNorm2d>();
    if (bn == nullptr) continue;
    // momentum 0 keeps running = (1 - 0) * running + 0 * batch exactly
    bn->options.momentum(
        on ? 0.0 : torch::nn::BatchNormOptions(1).momentum().value());
    bn->train(on);
  }
}

void ObservationEncoderImpl::train(bool on) {
  torch::nn::Module::train(on);
  if (rgb && !config_.rgb_trainable) rgb->train(false);
  if (depth && !config_.depth_trainable) depth->train(false);
}

}  // namespace vln::models
