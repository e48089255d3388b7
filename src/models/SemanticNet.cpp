#include "models/SemanticNet.h"

namespace vln::models {

SemanticNetImpl::SemanticNetImpl(const ModelConfig& model, int64_t categories,
                                 int64_t colors, int64_t rooms) {
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
