#pragma once
// Reading an exported TorchScript archive (models/Export.h,
// models/WaypointExport.h) for evaluation: integrity first, then LibTorch's
// loader, then the model config the export stores. Shared by the scripted
// low-level agent (ScriptedPolicyAgent.h) and the scripted waypoint model
// (ScriptedWaypointModel.h), and by `eval`, which picks between them.

#include <torch/script.h>

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "data/Episode.h"
#include "models/ModelConfig.h"

namespace vln::rollout {

/// `device` ("cpu", "cuda:1", ...) parsed; throws std::invalid_argument
/// naming `who` when it cannot be.
torch::Device parseDevice(const std::string& device, std::string_view who);

/// Loads `file` onto `device` ("cpu", "cuda", ...). Throws
/// std::runtime_error naming `who` and the file when it is missing, damaged
/// (its zip CRCs are checked first: LibTorch does not, and its parser can
/// crash on a damaged archive) or not a TorchScript archive, and
/// std::invalid_argument when `device` cannot be parsed.
torch::jit::Module loadExportedArchive(const std::filesystem::path& file,
                                       const std::string& device,
                                       std::string_view who);

/// The ModelConfig stored in an exported archive's `model_config` attribute;
/// `file` names it in errors.
models::ModelConfig exportedModelConfig(const torch::jit::Module& module,
                                        const std::filesystem::path& file);

/// Whether `module` is a waypoint policy's export (it has `num_views`).
bool isWaypointExport(const torch::jit::Module& module);

/// Checks that an archive of model `config` runs on raw observations as
/// the scripted agents feed it: instruction tokens (not text features) and
/// the encoders of the modalities it uses (encode_rgb, encode_depth; an
/// export without them takes features). Throws std::invalid_argument
/// naming `who` and `file`.
void checkRunsOnObservations(const torch::jit::Module& module,
                             const models::ModelConfig& config,
                             const std::filesystem::path& file,
                             std::string_view who);

/// The tokens an archive is fed for `episode`: its real tokens capped at
/// `maxLength` (the archive encodes by length, so padding is free); none
/// when the model reads no instruction. Throws std::invalid_argument when
/// an instruction is read and the episode has no tokens.
std::vector<int64_t> archiveTokens(const data::Episode& episode,
                                   const models::ModelConfig& config,
                                   int maxLength, std::string_view who);

/// Rows of archiveTokens() as int64 [n, longest] with PAD 0 on the right
/// (all 1 without an instruction, which the archive ignores).
at::Tensor tokenBatch(std::span<const std::vector<int64_t>* const> rows,
                      const models::ModelConfig& config);

}  // namespace vln::rollout
