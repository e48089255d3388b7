#pragma once
// TorchScript export of a trained agent: a self-contained archive that
// C++ (torch::jit::load) and Python (torch.jit.load) run without this
// project. The archive's code is generated from the modules' structure
// (TorchScript source compiled with define()), and its tensors are the
// modules' parameters and buffers, registered on the root module under
// their dotted names with "." replaced by "__" ("policy__action_head__weight").
//
// Methods of the exported module (B = batch, one step per call):
//   forward(rgb, depth, instruction, prev_action, not_done, hidden)
//       -> (logits, progress, hidden)
//     rgb uint8 [B, H, W, 3], depth float [B, H, W, 1] in [0, 1] (the raw
//     observations, encoded by the included CNNs). Without an encoder at
//     export time, forward takes features exactly like step_features.
//   step_features(rgb_features, depth_features, instruction, prev_action,
//                 not_done, hidden) -> (logits, progress, hidden)
//     rgb_features [B, C, h, w], depth_features [B, C', h', w'] float.
//   Common arguments: instruction int64 [B, L] (tokens then PAD 0), or with
//   model.instruction_features: rxr_text float [B, L, text_feature_dim]
//   (feature rows then zero rows, e.g. RxR's [B, 512, 768]); encoded again
//   at every call. prev_action int64 [B] in [0, num_actions), not_done
//   float [B] (0 at an episode's first step), hidden float [B, layers,
//   hidden_size] (zeros at the start). Returns logits [B, num_actions]
//   (model.num_actions: 4, or 6 with LOOK_UP / LOOK_DOWN), progress [B]
//   (zeros without a progress monitor), hidden [B, layers, hidden_size].
//   Inputs of ablated modalities are ignored (pass any tensor).
// The attribute `model_config` holds the model's YAML config.
// The waypoint CMA has its own export (WaypointExport.h); both are generated
// from the pieces in ExportCodegen.h.

#include <torch/script.h>

#include <filesystem>

#include "models/ObservationEncoder.h"
#include "models/Policy.h"

namespace vln::models {

/// Writes `policy` (and `encoder`, when non-null) as a TorchScript archive
/// to `file` (atomically). The export is made on the CPU in float32 with
/// frozen encoders in eval mode; the modules themselves are not modified.
/// Throws std::invalid_argument when encoder and policy configs disagree on
/// the visual inputs, std::runtime_error on I/O failure.
void exportPolicy(PolicyImpl& policy, ObservationEncoderImpl* encoder,
                  const std::filesystem::path& file);

/// Same as exportPolicy() but returns the module instead of writing it.
torch::jit::Module buildExportModule(PolicyImpl& policy,
                                     ObservationEncoderImpl* encoder);

}  // namespace vln::models
