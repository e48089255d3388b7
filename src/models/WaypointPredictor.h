#pragma once
// The learned candidate-waypoint predictor (issue 18), after Hong et al.'s
// TRM_net (CVPR 2022, "Bridging the Gap Between Learning in Discrete and
// Continuous Environments for VLN"): per-view features of a panorama's N
// views (the project's frozen depth and/or RGB encoders, flattened) become
// one token per view, a small transformer relates each view to its
// neighbours, and a head shared by the views turns each token into its
// share of the 120 x 12 heatmap (docs/waypoints.md).
//
// Layout: the views come in the panorama's order (view k looks k * 360/N
// degrees counter-clockwise of the agent's heading, at position k), and
// the logits are [B, 120, 12] in the heatmap layout of waypoint/
// WaypointHeatmap.h. Each view emits B = 120/N heading bins centred on its
// optical axis: its output j covers bin k*B - B/2 + j (wrapping), so with
// 12 views view k emits bins 10k-5 .. 10k+4 and bin 10k is its axis
// (Hong et al. roll their output by the same half view).
//
// Rotation equivariance: tokens carry no absolute position; attention is
// masked to `neighbors` views on each side and biased by a learned term
// per circular offset, and the head is shared, so turning the agent by one
// view (rolling the views by one) rolls the logits by exactly B bins.

#include <torch/torch.h>

#include <cstdint>
#include <numbers>
#include <string_view>

#include "models/ModelConfig.h"
#include "models/WaypointPredictorConfig.h"

namespace vln::models {

/// The heatmap's size (waypoint/WaypointHeatmap.h: kNumHeadings,
/// kNumDistances; models does not depend on that module).
inline constexpr int64_t kWaypointHeadings = 120;
inline constexpr int64_t kWaypointDistances = 12;
/// A heading bin's width (radians, float as waypoint::kHeadingStep) and a
/// distance bin's (m; bin d is at (d + 1) * kWaypointDistanceStep).
inline constexpr float kWaypointHeadingStep =
    2.0f * std::numbers::pi_v<float> / kWaypointHeadings;
inline constexpr float kWaypointDistanceStep = 0.25f;

/// Places the views' outputs [Bt, N, (120/N) * 12] (view k's output j * 12
/// + d is heading j of the view, distance d) into the heatmap layout
/// [Bt, 120, 12]: view k's heading j goes to bin (k * 120/N - 120/(2N) + j)
/// mod 120. N must divide 120.
torch::Tensor viewOutputsToHeatmap(const torch::Tensor& perView);

/// One post-norm transformer layer over the view tokens with a circular
/// attention mask and a learned bias per circular offset.
class ViewAttentionLayerImpl : public torch::nn::Module {
 public:
  ViewAttentionLayerImpl(const WaypointPredictorConfig& config,
                         int64_t numViews);
  /// [Bt, N, hidden] -> [Bt, N, hidden].
  torch::Tensor forward(const torch::Tensor& x);

  torch::nn::Linear qkv{nullptr}, out{nullptr}, ff1{nullptr}, ff2{nullptr};
  torch::nn::LayerNorm norm1{nullptr}, norm2{nullptr};
  torch::nn::Dropout dropout{nullptr};
  torch::Tensor offset_bias;  ///< [heads, N], by (key - query) mod N
  torch::Tensor mask;         ///< [N, N] additive: 0 or -inf (buffer)
  torch::Tensor offsets;      ///< [N, N] int64 (key - query) mod N (buffer)

 private:
  int64_t heads_;
};
TORCH_MODULE(ViewAttentionLayer);

class WaypointPredictorImpl : public torch::nn::Module {
 public:
  /// `depthFeatures` / `rgbFeatures`: the flattened encoder feature size of
  /// one view (0: the modality is not used; at least one is positive).
  /// Throws std::invalid_argument when numViews does not divide 120, or
  /// what config.validate() throws.
  WaypointPredictorImpl(const WaypointPredictorConfig& config, int64_t numViews,
                        int64_t depthFeatures, int64_t rgbFeatures);
  /// depth [Bt, N, depthFeatures], rgb [Bt, N, rgbFeatures] (undefined for
  /// an unused modality) -> logits [Bt, 120, 12].
  torch::Tensor forward(const torch::Tensor& depth, const torch::Tensor& rgb);

  int64_t numViews() const { return numViews_; }

  torch::nn::Sequential depth_fc{nullptr}, rgb_fc{nullptr}, merge{nullptr};
  torch::nn::ModuleList layers{nullptr};
  torch::nn::Sequential head{nullptr};

 private:
  int64_t numViews_;
};
TORCH_MODULE(WaypointPredictor);

/// The predictor of `numViews` views whose features come from `model`'s
/// encoders (depthFeatureShape() / rgbFeatureShape() flattened; none for
/// model.no_depth, nor RGB unless predictorReadsRgb()): what the training
/// task builds and what its weight file loads into.
WaypointPredictor makeWaypointPredictor(const ModelConfig& model,
                                        const WaypointPredictorConfig& config,
                                        int64_t numViews);

/// Whether the predictor reads RGB features: the model has them
/// (model.no_rgb false) and waypoint.predictor.rgb asks for them.
bool predictorReadsRgb(const ModelConfig& model,
                       const WaypointPredictorConfig& config);

/// Throws std::invalid_argument "<where>: ..." naming the keys when the
/// predictor would read no features (model.no_depth, and no RGB by
/// predictorReadsRgb()): what the tasks check before rendering anything.
void checkPredictorInputs(const ModelConfig& model,
                          const WaypointPredictorConfig& config,
                          std::string_view where);

/// Training losses against a target heatmap [Bt, 120, 12] (peak 1).
enum class WaypointLoss {
  /// Hong et al.'s: squared error of the raw logits against target *
  /// targetScale (theirs: targets of peak 10), summed over the cells,
  /// divided by 120 and averaged over the batch.
  kMse,
  /// Cross-entropy of the softmax over all 1440 cells (what evaluation
  /// reads) against the target normalised to sum 1, averaged over the
  /// batch; targetScale is unused.
  kSoftmax,
};

/// The loss of `logits` [Bt, 120, 12] against `targets` [Bt, 120, 12].
torch::Tensor waypointLoss(const torch::Tensor& logits,
                           const torch::Tensor& targets, WaypointLoss kind,
                           double targetScale);

/// Softmax over each heatmap's 1440 cells, the map that non-maximum
/// suppression reads (as Hong et al. evaluate): [Bt, 120, 12].
torch::Tensor waypointProbabilities(const torch::Tensor& logits);

}  // namespace vln::models
