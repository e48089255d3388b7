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
// Headings follow docs/waypoints.md: radians counter-clockwise seen from
// above (turning left), relative to the agent's heading when the panorama
// was taken; view k looks k * 2 pi / N to the left of view 0, and each
// candidate reads the view nearest its heading.
//
// The candidate waypoint predictor (WaypointPredictor.h) is not part of the
// archive: the caller supplies the candidates (its own predictor, this
// project's after heatmap NMS, or the depth-only baseline of
// waypoint/DepthWaypointBaseline.h) and executes the chosen one.
// Attributes: `model_config` (the model's YAML config) and `num_views`.

#include <torch/script.h>

#include <filesystem>

#include "models/ObservationEncoder.h"
#include "models/WaypointCmaPolicy.h"

namespace vln::models {

/// Writes `policy` (and `encoder`, when non-null) as a TorchScript archive
/// to `file` (atomically). The export is made on the CPU in float32; the
/// modules themselves are not modified. Throws std::invalid_argument when
/// the encoder's features do not fit the policy, std::runtime_error on I/O
/// failure.
void exportWaypointPolicy(WaypointCmaPolicyImpl& policy,
                          ObservationEncoderImpl* encoder,
                          const std::filesystem::path& file);

/// Same as exportWaypointPolicy() but returns the module instead of
/// writing it.
torch::jit::Module buildWaypointExportModule(WaypointCmaPolicyImpl& policy,
                                             ObservationEncoderImpl* encoder);

}  // namespace vln::models
