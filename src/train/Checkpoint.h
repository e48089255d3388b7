#pragma once
// Training checkpoints: everything needed to resume a run after a kill -9
// (policy weights, optimizer state, the resolved config, where training was,
// RNG states) in one file, written atomically (temporary file, fsync,
// rename), so a crash leaves either the old or the new checkpoint, never a
// torn one. Policy tensors are strictly loaded (models/StateDict.h).

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "models/Policy.h"
#include "models/StateDict.h"

namespace vln::train {

/// Where training stood when the checkpoint was written.
struct TrainingProgress {
  int checkpoint_index = 0;        ///< ckpt.<index>.pth, increasing
  int dagger_iteration = 0;        ///< completed DAgger iterations
  int epoch = 0;                   ///< completed epochs in the current stage
  int64_t updates = 0;             ///< optimizer steps so far
  int64_t episodes_collected = 0;  ///< episodes in the store when written
  std::string stage;               ///< "teacher_forcing", "dagger", ...
  double best_spl = -1.0;  ///< best selection-split SPL so far (-1: none)
  int best_checkpoint = -1;
  nlohmann::json extra = nlohmann::json::object();  ///< stage-specific state
};

/// A checkpoint's contents.
struct Checkpoint {
  std::string config_yaml;      ///< the resolved ExperimentConfig
  models::NamedTensors policy;  ///< policy parameters and buffers
  std::string
      optimizer_state;  ///< serialised torch::optim::Adam (may be empty)
  TrainingProgress progress;
  std::string rng_state;  ///< serialised RNG states (opaque)
};

/// "ckpt.<index>.pth".
std::string checkpointFileName(int index);

/// Writes `checkpoint` to `file` atomically. Throws std::runtime_error naming
/// the file on any I/O failure (disk full, file size limit), leaving a
/// previous file of that name intact.
void saveCheckpoint(const std::filesystem::path& file,
                    const Checkpoint& checkpoint);

/// Reads a checkpoint. Throws std::runtime_error naming the file when it is
/// missing, truncated or not a checkpoint of this project.
Checkpoint loadCheckpoint(const std::filesystem::path& file);

/// The bytes saveCheckpoint() writes (a torch::serialize archive: format,
/// version, config_yaml, progress JSON, optimizer_state and rng_state as
/// uint8 tensors, policy tensors by position with their names as JSON).
std::string serializeCheckpoint(const Checkpoint& checkpoint);

/// The state of `optimizer` (Adam's step counts and moments per parameter)
/// as bytes for Checkpoint::optimizer_state.
std::string serializeOptimizer(const torch::optim::Optimizer& optimizer);

/// Sets every parameter group's learning rate (Adam's options; the
/// optimizer's moments are kept).
void setAdamLearningRate(torch::optim::Optimizer& optimizer, double lr);
/// The first parameter group's learning rate (Adam's options): the rate
/// the next update takes, for the metrics.
double adamLearningRate(const torch::optim::Optimizer& optimizer);

/// Restores serializeOptimizer() bytes into an optimizer over the same
/// parameters. Throws std::runtime_error naming `source` when they do not
/// fit (other parameters, corrupt bytes).
void loadOptimizerState(torch::optim::Optimizer& optimizer,
                        std::string_view bytes, const std::string& source);

/// Parses serializeCheckpoint() bytes; `source` names them in errors.
Checkpoint deserializeCheckpoint(std::string_view bytes,
                                 const std::string& source);

/// The checkpoint files of a directory (ckpt.<index>.pth), by increasing
/// index; empty when there are none.
std::vector<std::filesystem::path> listCheckpoints(
    const std::filesystem::path& dir);

/// Index parsed from a checkpoint file name, or nullopt.
std::optional<int> checkpointIndex(const std::filesystem::path& file);

/// checkpoints/best.json's checkpoint when present, else the newest
/// checkpoint of `runDir`. Throws std::runtime_error naming the directory
/// when there is none.
std::filesystem::path bestOrLatestCheckpoint(
    const std::filesystem::path& runDir);

/// The policy tensors trainer.init_checkpoint names: one of our
/// checkpoints, a run directory (bestOrLatestCheckpoint(): how a DA*
/// config names the run it fine-tunes) or a TorchScript tensor file
/// (models/StateDict.h). Throws std::runtime_error naming the file when it
/// is none of them.
models::NamedTensors readPolicyWeights(const std::filesystem::path& given);

/// LibTorch's default CPU generator state as bytes (Checkpoint::rng_state).
std::string captureRngState();

/// A training run's state now: its config (as YAML), the policy's weights
/// (any policy module: the low-level policies, the waypoint CMA),
/// the optimizer's state, `progress` and the generator state.
Checkpoint trainingCheckpoint(const std::string& configYaml,
                              const torch::nn::Module& policy,
                              const torch::optim::Optimizer& optimizer,
                              const TrainingProgress& progress);
/// Restores captureRngState() bytes (nothing when empty); throws
/// std::runtime_error naming `source` when they are not a generator state.
void restoreRngState(const std::string& bytes, const std::string& source);

}  // namespace vln::train
