#pragma once
// TorchScript export of the waypoint CMA policy (WaypointCmaPolicy.h;
// issue 18, docs/waypoints.md), as Export.h exports the low-level agents: a
// self-contained archive that C++ (torch::jit::load) and Python
// (torch.jit.load) run without this project, its code generated from the
// policy's structure (ExportCodegen.h) and its tensors the policy's (and
// the encoders') parameters and buffers, registered on the root module as
// "policy__<name>" / "encoder__<name>".
//
// Methods of the exported module (B = batch, one decision per call; N =
// panorama views, K = candidate slots, any K >= 0; H = model.hidden_size):
//   forward(rgb, depth, instruction, candidates, candidate_mask, prev,
//           not_done, hidden) -> (logits, hidden)
//     rgb uint8 [B, N, h, w, 3], depth float [B, N, h, w, 1] in [0, 1]: the
//     panorama's views (sim::Simulator::observePanorama()), encoded by the
//     included CNNs view by view. Without an encoder at export time,
//     forward takes features exactly like step_features.
//   step_features(rgb_features, depth_features, instruction, candidates,
//                 candidate_mask, prev, not_done, hidden) -> (logits, hidden)
//     rgb_features [B, N, F_rgb], depth_features [B, N, F_depth] float: each
//     view's encoder features flattened (F = C * h * w of rgbFeatureShape()
//     / depthFeatureShape(); [B, N, C, h, w] is accepted too).
//   Common arguments: instruction int64 [B, L] (tokens then PAD 0; encoded
//   again at every call, trailing PAD columns dropped); candidates float
//   [B, K, 2]: relative heading (radians), distance (m) of each slot;
//   candidate_mask bool [B, K], true at real candidates (other slots'
//   values are ignored); prev float [B, 2]: heading and distance of the
//   previous decision's chosen candidate, as it was given then (ignored
//   where not_done is 0); not_done float [B] (0 at an episode's first
//   decision); hidden float [B, 2, H] (zeros at the start). Returns logits
//   [B, 1 + K] (index 0 STOP, j >= 1 candidate j - 1, -inf at masked
//   slots; the agent takes the argmax or samples the softmax) and hidden
//   [B, 2, H] for the next decision. Inputs of ablated modalities
//   (model.no_rgb, no_depth, no_instruction) are ignored (pass any tensor).
//   With model.goal_match (model_config says so) both methods take one
//   more argument after instruction, goal_labels float [B, F_rgb]: for
//   each row the label groups world::goalLabels() finds in its
//   instruction's text (0 for a label the goal clause does not name, 1
//   category, 2 colour, 3 room; one row per episode, the same at each of
//   its decisions), computed by the caller as the tokens are. The RGB
//   features are then the semantic heads' probabilities (what encode_rgb
//   gives with model.rgb_semantic_outputs) and reach the policy only as
//   their match with those labels (WaypointCmaPolicy.h).
// Headings follow docs/waypoints.md: radians counter-clockwise seen from
// above (turning left), relative to the agent's heading when the panorama
// was taken; view k looks k * 2 pi / N to the left of view 0, and each
// candidate reads the view nearest its heading.
//
// With a predictor at export time (WaypointPredictor.h, the agent's
// waypoint_agent.candidates: predictor), the archive also proposes the
// candidates, as rollout::WaypointAgent does (has_predictor is true):
//   propose(rgb, depth) -> (candidates, candidate_mask)          [encoder]
//   propose_features(rgb_features, depth_features)
//       -> (candidates float [B, K, 2], candidate_mask bool [B, K])
//     K = max_candidates; the predictor's heatmap through non-maximum
//     suppression exactly as waypoint::heatmapNms() (ordered by decreasing
//     probability, masked slots zero), ready for forward/step_features.
//   heatmap_features(rgb_features, depth_features) -> float [B, 120, 12]
//     the softmax over the 1440 cells that the suppression reads
//     (waypoint/WaypointHeatmap.h's layout: bin h at h * 3 degrees
//     counter-clockwise, distance bin d at (d + 1) * 0.25 m).
// Without one (has_predictor false; the depth-only baseline's agents) the
// caller supplies the candidates (its own predictor or the depth-only
// baseline of waypoint/DepthWaypointBaseline.h). Either way the caller
// executes the chosen waypoint.
// Attributes: `model_config` (the model's YAML config), `num_views`,
// `has_predictor`, and with a predictor `max_candidates`,
// `nms_heading_radius`, `nms_distance_radius`, `nms_min_score`.

#include <torch/script.h>

#include <filesystem>

#include "models/ObservationEncoder.h"
#include "models/WaypointCmaPolicy.h"
#include "models/WaypointPredictor.h"

namespace vln::models {

/// The candidate predictor to include and its non-maximum suppression
/// (waypoint::heatmapNms()'s arguments; the agent's waypoint.nms_*).
struct ExportedPredictor {
  WaypointPredictorImpl* predictor = nullptr;
  int64_t max_candidates = 5;
  int64_t heading_radius = 7;
  int64_t distance_radius = 5;
  double min_score = 0.0;
};

/// Writes `policy` (and `encoder` and `predictor`, when non-null) as a
/// TorchScript archive to `file` (atomically). The export is made on the
/// CPU in float32; the modules themselves are not modified. Throws
/// std::invalid_argument when the encoder's features do not fit the policy
/// or the predictor (its views, its modalities), or the suppression's
/// settings are negative; std::runtime_error on I/O failure.
void exportWaypointPolicy(WaypointCmaPolicyImpl& policy,
                          ObservationEncoderImpl* encoder,
                          const std::filesystem::path& file,
                          const ExportedPredictor& predictor = {});

/// Same as exportWaypointPolicy() but returns the module instead of
/// writing it.
torch::jit::Module buildWaypointExportModule(
    WaypointCmaPolicyImpl& policy, ObservationEncoderImpl* encoder,
    const ExportedPredictor& predictor = {});

}  // namespace vln::models
