#include "models/WaypointPredictor.h"

#include <cmath>
#include <limits>

#include "common/Check.h"

namespace vln::models {
namespace nn = torch::nn;

torch::Tensor viewOutputsToHeatmap(const torch::Tensor& perView) {
  TORCH_CHECK(perView.dim() == 3,
              "viewOutputsToHeatmap(): expected [Bt, N, bins * 12], got ",
              perView.sizes());
  const int64_t views = perView.size(1);
  TORCH_CHECK(views > 0 && kWaypointHeadings % views == 0,
              "viewOutputsToHeatmap(): ", views, " views do not divide ",
              kWaypointHeadings, " headings");
  const int64_t bins = kWaypointHeadings / views;
  TORCH_CHECK(perView.size(2) == bins * kWaypointDistances,
              "viewOutputsToHeatmap(): expected ", bins * kWaypointDistances,
              " outputs per view, got ", perView.size(2));
  // view k's output j lands at k * bins + j before the roll; rolling back
  // by half a view centres the view's bins on its axis
  const torch::Tensor stacked =
      perView.reshape({perView.size(0), kWaypointHeadings, kWaypointDistances});
  return torch::roll(stacked, {-(bins / 2)}, {1});
}

// ===========================================================================
// ViewAttentionLayer
// ===========================================================================

ViewAttentionLayerImpl::ViewAttentionLayerImpl(
    const WaypointPredictorConfig& config, int64_t numViews)
    : heads_(config.heads) {
  const int64_t h = config.hidden_size;
  qkv = register_module("qkv", nn::Linear(h, 3 * h));
  out = register_module("out", nn::Linear(h, h));
  ff1 = register_module("ff1", nn::Linear(h, config.ff_size));
  ff2 = register_module("ff2", nn::Linear(config.ff_size, h));
  norm1 = register_module("norm1", nn::LayerNorm(nn::LayerNormOptions({h})));
  norm2 = register_module("norm2", nn::LayerNorm(nn::LayerNormOptions({h})));
  dropout = register_module("dropout", nn::Dropout(config.dropout));
  offset_bias =
      register_parameter("offset_bias", torch::zeros({config.heads, numViews}));
  // circular offsets and the neighbourhood mask depend on (key - query)
  // mod N only: what keeps the layer equivariant to rolling the views
  const torch::Tensor index = torch::arange(numViews, torch::kInt64);
  const torch::Tensor offset =
      torch::remainder(index.unsqueeze(0) - index.unsqueeze(1), numViews);
  const torch::Tensor circular = torch::minimum(offset, numViews - offset);
  torch::Tensor additive = torch::zeros({numViews, numViews});
  if (config.neighbors >= 0)
    additive.masked_fill_(circular > config.neighbors,
                          -std::numeric_limits<float>::infinity());
  offsets = register_buffer("offsets", offset);
  mask = register_buffer("mask", additive);
}

torch::Tensor ViewAttentionLayerImpl::forward(const torch::Tensor& x) {
  const int64_t batch = x.size(0);
  const int64_t views = x.size(1);
  const int64_t hidden = x.size(2);
  const int64_t headSize = hidden / heads_;
  // [Bt, N, 3, heads, headSize] -> three [Bt, heads, N, headSize]
  const torch::Tensor parts =
      qkv->forward(x).view({batch, views, 3, heads_, headSize});
  const torch::Tensor q = parts.select(2, 0).transpose(1, 2);
  const torch::Tensor k = parts.select(2, 1).transpose(1, 2);
  const torch::Tensor v = parts.select(2, 2).transpose(1, 2);
  // bias[h, i, j] = offset_bias[h, (j - i) mod N]
  const torch::Tensor bias = offset_bias.index_select(1, offsets.reshape({-1}))
                                 .view({heads_, views, views});
  const torch::Tensor scores = torch::matmul(q, k.transpose(-2, -1)) /
                                   std::sqrt(static_cast<double>(headSize)) +
                               bias.unsqueeze(0) + mask;
  const torch::Tensor attention = dropout->forward(torch::softmax(scores, -1));
  const torch::Tensor context = torch::matmul(attention, v)
                                    .transpose(1, 2)
                                    .reshape({batch, views, hidden});
  const torch::Tensor y =
      norm1->forward(x + dropout->forward(out->forward(context)));
  const torch::Tensor ff =
      ff2->forward(dropout->forward(torch::gelu(ff1->forward(y))));
  return norm2->forward(y + dropout->forward(ff));
}

// ===========================================================================
// WaypointPredictor
// ===========================================================================

WaypointPredictorImpl::WaypointPredictorImpl(
    const WaypointPredictorConfig& config, int64_t numViews,
    int64_t depthFeatures, int64_t rgbFeatures)
    : numViews_(numViews) {
  config.validate("WaypointPredictor");
  VLN_CHECK_ARG(numViews > 0 && kWaypointHeadings % numViews == 0,
                "WaypointPredictor: ", numViews, " views do not divide the ",
                kWaypointHeadings, " heading bins");
  VLN_CHECK_ARG(depthFeatures > 0 || rgbFeatures > 0,
                "WaypointPredictor: neither depth nor RGB features");
  const int64_t h = config.hidden_size;
  if (depthFeatures > 0)
    depth_fc = register_module(
        "depth_fc", nn::Sequential(nn::Linear(depthFeatures, h), nn::ReLU()));
  if (rgbFeatures > 0)
    rgb_fc = register_module(
        "rgb_fc", nn::Sequential(nn::Linear(rgbFeatures, h), nn::ReLU()));
  if (depth_fc && rgb_fc)
    merge = register_module("merge",
                            nn::Sequential(nn::Linear(2 * h, h), nn::ReLU()));
  layers = register_module("layers", nn::ModuleList());
  for (int i = 0; i < config.layers; ++i)
    layers->push_back(ViewAttentionLayer(config, numViews));
  const int64_t bins = kWaypointHeadings / numViews;
  head = register_module(
      "head", nn::Sequential(nn::Linear(h, h), nn::ReLU(),
                             nn::Linear(h, bins * kWaypointDistances)));
}

torch::Tensor WaypointPredictorImpl::forward(const torch::Tensor& depth,
                                             const torch::Tensor& rgb) {
  auto checked = [&](const torch::Tensor& t, const char* name) {
    TORCH_CHECK(t.defined(), "WaypointPredictor::forward(): the model uses ",
                name, " features but none were given");
    TORCH_CHECK(t.dim() == 3 && t.size(1) == numViews_,
                "WaypointPredictor::forward(): expected ", name,
                " features [Bt, ", numViews_, ", F], got ", t.sizes());
    return t;
  };
  torch::Tensor tokens;
  if (depth_fc && rgb_fc) {
    tokens =
        merge->forward(torch::cat({depth_fc->forward(checked(depth, "depth")),
                                   rgb_fc->forward(checked(rgb, "RGB"))},
                                  -1));
  } else if (depth_fc) {
    tokens = depth_fc->forward(checked(depth, "depth"));
  } else {
    tokens = rgb_fc->forward(checked(rgb, "RGB"));
  }
  for (const auto& layer : *layers)
    tokens = layer->as<ViewAttentionLayer>()->forward(tokens);
  return viewOutputsToHeatmap(head->forward(tokens));
}

WaypointPredictor makeWaypointPredictor(const ModelConfig& model,
                                        const WaypointPredictorConfig& config,
                                        int64_t numViews) {
  auto flat = [](const FeatureShape& shape) {
    int64_t n = 1;
    for (int64_t s : shape) n *= s;
    return n;
  };
  return WaypointPredictor(
      config, numViews, model.usesDepth() ? flat(depthFeatureShape(model)) : 0,
      predictorReadsRgb(model, config) ? flat(rgbFeatureShape(model)) : 0);
}

bool predictorReadsRgb(const ModelConfig& model,
                       const WaypointPredictorConfig& config) {
  return model.usesRgb() && config.rgb;
}

void checkPredictorInputs(const ModelConfig& model,
                          const WaypointPredictorConfig& config,
                          std::string_view where) {
  VLN_CHECK_ARG(model.usesDepth() || predictorReadsRgb(model, config), where,
                ": the candidate-waypoint predictor reads no features "
                "(model.no_depth is true and ",
                model.usesRgb() ? "waypoint.predictor.rgb is false"
                                : "model.no_rgb is true",
                ")");
}

// ===========================================================================
// losses
// ===========================================================================

torch::Tensor waypointLoss(const torch::Tensor& logits,
                           const torch::Tensor& targets, WaypointLoss kind,
                           double targetScale) {
  TORCH_CHECK(logits.sizes() == targets.sizes() && logits.dim() == 3 &&
                  logits.size(1) == kWaypointHeadings &&
                  logits.size(2) == kWaypointDistances,
              "waypointLoss(): expected logits and targets [Bt, ",
              kWaypointHeadings, ", ", kWaypointDistances, "], got ",
              logits.sizes(), " and ", targets.sizes());
  const int64_t batch = logits.size(0);
  if (kind == WaypointLoss::kMse) {
    const torch::Tensor error = logits - targets * targetScale;
    return error.pow(2).sum() / static_cast<double>(batch) /
           static_cast<double>(kWaypointHeadings);
  }
  const torch::Tensor flatTargets = targets.reshape({batch, -1});
  // a target map without mass would divide by zero; it has no gradient
  // to give either way
  const torch::Tensor distribution =
      flatTargets / flatTargets.sum(1, true).clamp_min(1e-12);
  const torch::Tensor logProbabilities =
      torch::log_softmax(logits.reshape({batch, -1}), 1);
  return -(distribution * logProbabilities).sum() / static_cast<double>(batch);
}

torch::Tensor waypointProbabilities(const torch::Tensor& logits) {
  return torch::softmax(logits.reshape({logits.size(0), -1}), 1)
      .view_as(logits);
}

}  // namespace vln::models
