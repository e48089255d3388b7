#pragma once
// Internal to the pretraining tasks (PointNavPretrainer.cpp and
// SemanticPretrainer.cpp; defined in PretrainTasks.cpp): the run state and
// the steps both tasks share, so that they start, update, skip non-finite
// losses and finish alike. Not part of the train API.

#include <torch/torch.h>

#include <cstdint>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/ThreadPool.h"
#include "train/ExperimentConfig.h"
#include "train/MetricsLog.h"
#include "train/PretrainTasks.h"

namespace vln::train {

/// What every pretraining run holds; the Impl of each task derives from it.
struct PretrainRun {
  ExperimentConfig config;
  std::filesystem::path runDir;
  torch::Device device{torch::kCPU};
  PretrainHouses houses;
  std::unique_ptr<common::ThreadPool> pool;  ///< trainer.env_threads threads
  std::unique_ptr<MetricsLog> metrics;       ///< from openMetrics()
  int64_t updates = 0;                       ///< optimizer steps taken
  /// Loss of the first batch, before any update (NaN until then).
  double initialLoss = std::numeric_limits<double>::quiet_NaN();

  /// The start of both constructors: keeps `runConfig` and `dir`, checks
  /// the config (validatePretrainConfig(), then trainer.task == `task`,
  /// else std::invalid_argument from `className`), picks the model's
  /// device, sets LibTorch's thread count and seed, and generates the
  /// houses on the pool (logged under `task`).
  void start(const ExperimentConfig& runConfig, std::filesystem::path dir,
             const std::string& task, const std::string& className);

  /// Opens <runDir>/metrics.jsonl (and <runDir>/tb with
  /// output.tensorboard).
  void openMetrics();

  /// The pretrain_metrics.json fields of every task: task, seconds, the
  /// houses and the updates.
  nlohmann::json summary(const std::string& task, double seconds) const;

  /// Writes `record` to <runDir>/pretrain_metrics.json and to the metrics
  /// log as the "finished" record with `scalars`.
  void finish(const nlohmann::json& record,
              const std::vector<std::pair<std::string, double>>& scalars);

  /// 0 .. count-1 in the order of common::deterministicShuffle() with the
  /// generator of common::deriveSeed(trainer.seed, stream).
  std::vector<int64_t> shuffledOrder(size_t count, uint64_t stream) const;
};

/// The non-finite losses of one trained model, skipped under the project's
/// numeric-fault policy (common/Check.h): skip, count, give up in a row.
struct NonFiniteLosses {
  int inARow = 0;
  int64_t total = 0;

  /// Counts a skipped loss at update `update` and warns; throws
  /// std::runtime_error ("<task>: ... lower pretrain.lr") once
  /// trainer.max_nonfinite_updates come in a row. `model` names the model
  /// where a task trains several; empty for a task's only model.
  void skip(const ExperimentConfig& config, const std::string& task,
            const std::string& model, int64_t update);
};

/// One optimizer step of `module` on `loss`, the gradients clipped to a
/// norm of `gradClip` when that is positive (trainer.grad_clip).
void applyUpdate(torch::optim::Optimizer& optimizer, torch::nn::Module& module,
                 const torch::Tensor& loss, double gradClip);

/// Number of scalars in the parameters of `module`.
int64_t parameterCount(const torch::nn::Module& module);

}  // namespace vln::train
