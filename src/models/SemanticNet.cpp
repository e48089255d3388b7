#include "models/SemanticNet.h"

#include "common/Check.h"

namespace vln::models {

SemanticNetImpl::SemanticNetImpl(const ModelConfig& model, int64_t categories,
                                 int64_t colors, int64_t rooms) {
  // the heads sit on the CNN's feature map; reading heads is for the agents
  VLN_CHECK_ARG(model.rgb_semantic_outputs == 0,
                "SemanticNet: model.rgb_semantic_outputs must be 0 while "
                "pretraining the heads it reads, got ",
                model.rgb_semantic_outputs);
  rgb = register_module("rgb", RgbEncoder(model));
  const FeatureShape shape = rgbFeatureShape(model);
  const int64_t features = shape[0] * shape[1] * shape[2];
  this->categories =
      register_module("categories", torch::nn::Linear(features, categories));
  this->colors = register_module("colors", torch::nn::Linear(features, colors));
  room = register_module("room", torch::nn::Linear(features, rooms));
}

SemanticLogits SemanticNetImpl::forward(const torch::Tensor& images) {
  TORCH_CHECK(images.dim() == 4,
              "SemanticNet::forward(): expected rgb [N, H, W, 3], got ",
              images.sizes());
  const torch::Tensor features = rgb->forward(images).flatten(1);
  return {categories->forward(features), colors->forward(features),
          room->forward(features)};
}

}  // namespace vln::models
