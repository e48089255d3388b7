#pragma once
// The `train` and `vlnce-export` binaries as plain functions over parsed
// options (the mains stay thin CLI11 layers; tests call these directly).

#include <filesystem>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

#include "train/ExperimentConfig.h"

namespace vln::train {

/// Options of `train`.
struct TrainOptions {
  std::filesystem::path config;        ///< run config YAML
  std::vector<std::string> overrides;  ///< --set section.key=value
  bool dry_run = false;                ///< print the resolved YAML and exit
  bool resume = false;                 ///< continue the run in output.dir
  std::filesystem::path
      export_path;  ///< --export: TorchScript of the best checkpoint
};

class Distributed;

/// Trains one trainer.task in an initialised run directory (config.yaml
/// written, logging and threads set up). `resume` as in TrainOptions;
/// `dist` makes this process one rank of a multi-process run (null: alone).
using TaskRunner = std::function<void(const ExperimentConfig& config,
                                      bool resume, Distributed* dist)>;

/// The runner of `task`: "vln" is VlnTrainer (one process or a rank of
/// several); the encoder pretraining tasks (depth_pointnav, rgb_semantic,
/// text_mlm)
/// train in one process only. Throws std::invalid_argument naming
/// trainer.task for a task this build cannot train.
TaskRunner taskRunner(const std::string& task);

/// `train`: loads the config strictly (file, --set overrides), prints it
/// for --dry-run, otherwise checks the run directory (fresh or --resume,
/// RunDirectory.h), writes config.yaml, sets up logging (console +
/// train.log), threads and seeds, runs the task and, with --export, exports
/// the best checkpoint. Returns the exit code.
int runTrain(const TrainOptions& options, std::ostream& out);

/// Options of `vlnce-export`.
struct ExportOptions {
  std::filesystem::path checkpoint;  ///< ckpt.<i>.pth
  std::filesystem::path
      config;                 ///< run config; empty: the one in the checkpoint
  std::filesystem::path out;  ///< TorchScript file
};

/// `vlnce-export`: checkpoint -> TorchScript (policy + encoders).
int runExport(const ExportOptions& options, std::ostream& out);

}  // namespace vln::train
