#include "train/TrainCommand.h"

#include <spdlog/spdlog.h>
#include <torch/torch.h>

#include <map>
#include <optional>

#include "common/App.h"
#include "common/Check.h"
#include "common/Config.h"
#include "common/FileIo.h"
#include "models/Export.h"
#include "models/ObservationEncoder.h"
#include "models/Policy.h"
#include "models/StateDict.h"
#include "models/WaypointExport.h"
#include "train/Checkpoint.h"
#include "train/DistributedTraining.h"
#include "train/PretrainTasks.h"
#include "train/RecollectTrainer.h"
#include "train/RunDirectory.h"
#include "train/TextPretrainer.h"
#include "train/VlnTrainer.h"
#include "train/WaypointAgentTrainer.h"
#include "train/WaypointPretrainer.h"

namespace vln::train {
namespace fs = std::filesystem;

namespace {

// why a waypoint run cannot be exported: its policy reads what an archive
// given images and words cannot compute, or what the archive does not hold
// yet; empty when it can be
std::string whyNotExported(const ExperimentConfig& config) {
  if (config.waypoint_agent.view_labels)
    return "waypoint_agent.view_labels is a diagnostic whose policy reads "
           "the views' true labels, which an archive given images cannot "
           "compute; it cannot be exported";
  if (config.waypoint_agent.leg_words_only)
    return "waypoint_agent.leg_words_only is a diagnostic whose policy reads "
           "only the words of the reference path's leg ahead, which an "
           "archive given the instruction cannot know; it cannot be exported";
  if (config.model.clause_tracker)
    return "model.clause_tracker's pointer and rule clauses are not in the "
           "TorchScript archive yet; such a policy is scored from its "
           "checkpoint";
  return "";
}

// `checkpoint` with `config`'s model (policy strictly loaded, the
// observation encoders with their pretrained weights) as TorchScript: the
// low-level agents (trainer.task vln) or the waypoint CMA (waypoint_cma)
void exportCheckpoint(const fs::path& checkpoint,
                      const ExperimentConfig& config, const fs::path& out) {
  const Checkpoint ckpt = loadCheckpoint(checkpoint);
  if (config.trainer.task == "waypoint_cma") {
    VLN_CHECK_ARG(whyNotExported(config).empty(),
                  "export: ", whyNotExported(config));
    // an agent of the learned predictor's candidates carries the predictor
    // and its suppression (models/WaypointExport.h: propose()); the
    // depth-only baseline's leaves the candidates to the caller
    WaypointAgentModels nets =
        makeWaypointAgentModels(config, /*withEmbeddings=*/false);
    models::loadStateStrict(*nets.policy, ckpt.policy, checkpoint.string());
    models::ExportedPredictor predictor;
    if (!nets.predictor.is_empty()) {
      const WaypointPretrainConfig& w = config.waypoint;
      predictor.predictor = nets.predictor.get();
      predictor.max_candidates = w.nms_max_candidates;
      predictor.heading_radius = w.nms_heading_radius;
      predictor.distance_radius = w.nms_distance_radius;
      predictor.min_score = w.nms_min_score;
    }
    models::exportWaypointPolicy(*nets.policy, nets.encoder.get(), out,
                                 predictor);
  } else {
    auto policy = models::makePolicy(config.model);
    models::loadStateStrict(*policy, ckpt.policy, checkpoint.string());
    models::ObservationEncoder encoder(config.model);
    encoder->loadPretrained();
    models::exportPolicy(*policy, encoder.get(), out);
  }
  spdlog::info("exported {} to {}", checkpoint.string(), out.string());
}

}  // namespace

TaskRunner taskRunner(const std::string& task) {
  // one entry per trainer.task. Pretraining runs are minutes long and keep
  // no resumable state: --resume on them is refused rather than silently
  // restarting from scratch.
  auto pretraining = [](void (*run)(const ExperimentConfig&, const fs::path&)) {
    // one process only: runTrain() refuses WORLD_SIZE > 1 for them
    return [run](const ExperimentConfig& config, bool resume, Distributed*) {
      VLN_CHECK_ARG(!resume, "train --resume: trainer.task '",
                    config.trainer.task, "' cannot resume; delete ",
                    config.output.dir, " and start again");
      validatePretrainConfig(config);
      run(config, config.output.dir);
    };
  };
  static const std::map<std::string, TaskRunner> runners = {
      {"vln",
       [](const ExperimentConfig& config, bool resume, Distributed* dist) {
         if (config.trainer.mode == "recollect") {
           VLN_CHECK_ARG(dist == nullptr,
                         "train: trainer.mode recollect trains in one process "
                         "only, but WORLD_SIZE=",
                         dist ? dist->worldSize() : 1,
                         " (unset WORLD_SIZE or set trainer.distributed: off)");
           RecollectTrainer trainer(config, resume);
           trainer.run();
           return;
         }
         VlnTrainer trainer(config, resume, dist);
         trainer.run();
       }},
      {"depth_pointnav", pretraining(&runDepthPointNavPretraining)},
      {"rgb_semantic", pretraining(&runRgbSemanticPretraining)},
      {"text_mlm", pretraining(&runTextMlmPretraining)},
      {"waypoint_predictor", pretraining(&runWaypointPredictorPretraining)},
      {"waypoint_cma",
       [](const ExperimentConfig& config, bool resume, Distributed* dist) {
         VLN_CHECK_ARG(!resume,
                       "train --resume: trainer.task 'waypoint_cma' cannot "
                       "resume; delete ",
                       config.output.dir, " and start again");
         VLN_CHECK_ARG(dist == nullptr,
                       "train: trainer.task waypoint_cma trains in one "
                       "process only (unset WORLD_SIZE or set "
                       "trainer.distributed: off)");
         runWaypointAgentTraining(config, config.output.dir);
       }}};
  auto it = runners.find(task);
  VLN_CHECK_ARG(it != runners.end(), "train: trainer.task '", task,
                "' is unknown (available: vln, depth_pointnav, rgb_semantic, "
                "text_mlm, waypoint_predictor, waypoint_cma)");
  return it->second;
}

int runTrain(const TrainOptions& options, std::ostream& out) {
  const ExperimentConfig config =
      loadExperimentConfig(options.config, options.overrides);
  const std::string yaml = experimentConfigYaml(config);
  VLN_CHECK_ARG(
      options.export_path.empty() || config.trainer.task == "vln" ||
          config.trainer.task == "waypoint_cma",
      "train --export: trainer.task '", config.trainer.task,
      "' trains an encoder, not a policy; it is saved to pretrain.encoder_out");
  // refused before training rather than after it
  VLN_CHECK_ARG(options.export_path.empty() || whyNotExported(config).empty(),
                "train --export: ", whyNotExported(config));
  if (options.dry_run) {
    out << yaml;
    return 0;
  }
  // several processes when torchrun's variables ask for it
  // (DistributedTraining.h); rankConfig may name this rank's GPU
  ExperimentConfig rankConfig = config;
  const std::unique_ptr<Distributed> dist = connectForTraining(rankConfig);
  const bool master = !dist || dist->isMaster();
  if (dist) {
    VLN_CHECK_ARG(
        config.trainer.task == "vln", "train: trainer.task '",
        config.trainer.task,
        "' trains in one process only, but WORLD_SIZE=", dist->worldSize(),
        " (unset WORLD_SIZE or set "
        "trainer.distributed: off)");
    checkSameConfigOnAllRanks(*dist, config);
    // every rank resumes, or none (a fresh rank 0 would otherwise train
    // from scratch next to ranks that reopened their store shards)
    const double resuming =
        dist->allReduceSum({options.resume ? 1.0 : 0.0}).front();
    VLN_CHECK_ARG(resuming == 0.0 || resuming == dist->worldSize(),
                  "train: --resume was given to ", resuming, " of the ",
                  dist->worldSize(),
                  " ranks; give it to every rank or to none");
  }
  const fs::path runDir = config.output.dir;
  auto checkRunDirectory = [&] {
    if (options.resume) {
      // rank 0 owns config.yaml; the others run rank 0's config (checked).
      // The process count first: a run cannot change it at all.
      if (master) {
        checkRunWorldSize(runDir, dist ? dist->worldSize() : 1, options.resume);
        const auto changed = checkResumeConfig(
            runDir, config, overriddenKeys(options.overrides));
        for (const auto& key : changed)
          out << "train --resume: " << key << " changed (allowed)\n";
      }
    } else {
      checkFreshRunDirectory(runDir);
    }
  };
  if (dist)
    dist->collectively("the run directory check", checkRunDirectory);
  else
    checkRunDirectory();
  fs::create_directories(runDir);
  // rank 0 speaks for the run: another train on this directory stops here
  std::optional<RunDirectoryLock> lock;
  if (master) lock.emplace(runDir);
  if (master) common::writeFileAtomic(runDir / "config.yaml", yaml);
  if (dist && master && !options.resume)
    writeRunWorldSize(runDir, dist->worldSize());
  common::initLogging(rankLogFile(runDir, dist ? dist->rank() : 0),
                      config.output.log_level);
  if (dist)
    spdlog::set_pattern(
        strCat("[%H:%M:%S.%e] [rank ", dist->rank(), "] [%^%l%$] %v"));
  spdlog::info("train {} in {}{}", config.trainer.task, runDir.string(),
               options.resume ? " (resume)" : "");
  // a kill during an atomic write leaves its temporary behind
  if (options.resume && master)
    for (const auto& stale : common::removeStaleTemporaries(runDir))
      spdlog::info("removed {}, left by a killed write", stale.string());

  // threads and seeds before anything builds a model
  common::setBlasThreadsEnv(config.trainer.torch_threads);
  torch::set_num_threads(config.trainer.torch_threads);
  torch::manual_seed(static_cast<uint64_t>(config.trainer.seed));

  try {
    taskRunner(config.trainer.task)(rankConfig, options.resume, dist.get());
  } catch (const std::exception& error) {
    // the other ranks stop at their next wait instead of timing out
    if (dist) dist->abort(error.what());
    throw;
  }

  if (!options.export_path.empty() && master) {
    const fs::path source = bestOrLatestCheckpoint(runDir);
    exportCheckpoint(source, config, options.export_path);
    out << "exported " << source.string() << " to "
        << options.export_path.string() << "\n";
  }
  return 0;
}

int runExport(const ExportOptions& options, std::ostream& out) {
  ExperimentConfig config;
  if (!options.config.empty()) {
    config = loadExperimentConfig(options.config);
  } else {
    const Checkpoint ckpt = loadCheckpoint(options.checkpoint);
    config = common::loadConfigText<ExperimentConfig>(
        ckpt.config_yaml, options.checkpoint.string() + " config");
  }
  torch::set_num_threads(config.trainer.torch_threads);
  exportCheckpoint(options.checkpoint, config, options.out);
  out << "exported " << options.checkpoint.string() << " to "
      << options.out.string() << "\n";
  return 0;
}

}  // namespace vln::train
