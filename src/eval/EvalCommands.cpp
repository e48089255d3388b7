#include "eval/EvalCommands.h"

#include <spdlog/spdlog.h>
#include <torch/torch.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <memory>
#include <span>

#include "common/App.h"
#include "common/Check.h"
#include "common/FileIo.h"
#include "common/Json.h"
#include "common/Progress.h"
#include "data/Episode.h"
#include "data/GroundTruth.h"
#include "data/NavGraph.h"
#include "data/NodeTransfer.h"
#include "data/RxrEpisodes.h"
#include "data/Split.h"
#include "data/TransferConfig.h"
#include "eval/BaselineAgents.h"
#include "eval/PaperFindings.h"
#include "eval/Tables.h"
#include "models/ObservationEncoder.h"
#include "models/Policy.h"
#include "rollout/Evaluator.h"
#include "rollout/ObservationBatch.h"
#include "rollout/PolicyAgent.h"
#include "rollout/ScriptedPolicyAgent.h"
#include "rollout/ScriptedWaypointModel.h"
#include "rollout/VectorEnv.h"
#include "train/WaypointAgentTrainer.h"
#include "train/WaypointPretrainer.h"
#include "train/Checkpoint.h"
#include "viz/EpisodePictures.h"
#include "viz/EpisodeReport.h"
#include "viz/LearningCurve.h"

namespace vln::eval {
namespace fs = std::filesystem;

namespace {

// ---------------------------------------------------------------------------
// inputs

// one split's episodes (capped) and, with goals, its ground truth
data::Split loadSplit(const train::ExperimentConfig& config,
                      const std::string& name, int cap) {
  const fs::path root = config.dataset.data_path;
  data::Split split = data::loadDatasetSplit(config.dataset, name, cap);
  VLN_CHECK_ARG(!split.episodes.empty(), "eval: split '", name, "' under '",
                root.string(), "' has no episodes");
  return split;
}

// the hidden goals and ground truth of the test split (eval
// --test-ground-truth); errors keep their type and name the option
void attachTestGroundTruth(data::Split& split, const fs::path& given,
                           const data::DatasetConfig& dataset,
                           std::ostream& out) {
  const std::string option = "eval --test-ground-truth: ";
  try {
    if (dataset.isRxr()) {
      data::attachHiddenRxrGoals(split, given, dataset.rxr_filter);
      out << split.name << ": scored from the hidden goals and ground truth "
          << "under " << given.string() << "\n";
      return;
    }
    const data::HiddenSplitFiles files =
        data::findHiddenFiles(given, split.name);
    data::attachHiddenGoals(split, files);
    out << split.name << ": scored from the hidden goals "
        << files.goals.string() << " and ground truth "
        << files.ground_truth.string() << "\n";
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(option + e.what());
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(option + e.what());
  }
}

// one thing to evaluate: a checkpoint, an export or a baseline
struct Candidate {
  int index = 0;
  std::string label;     // for logs: the file or the baseline name
  fs::path checkpoint;   // set for checkpoint files
  fs::path scripted;     // set for TorchScript exports
  std::string baseline;  // set for baselines
};

std::unique_ptr<rollout::Agent> policyAgent(
    const train::ExperimentConfig& config, const fs::path& checkpoint,
    std::span<const fs::path> ensemble) {
  const models::NamedTensors weights = train::loadCheckpoint(checkpoint).policy;
  if (config.trainer.task == "waypoint_cma") {
    train::validateWaypointAgentConfig(config);
    train::WaypointAgentModels nets =
        train::makeWaypointAgentModels(config, /*withEmbeddings=*/false);
    models::loadStateStrict(*nets.policy, weights, checkpoint.string());
    train::addEnsembleMembers(nets, config, ensemble);
    return train::makeWaypointAgent(config, nets, config.eval.num_envs,
                                    config.eval.sample_actions,
                                    static_cast<uint64_t>(config.eval.seed));
  }
  // the trainer's construction order under its seed, so that encoders
  // without weight files get the initialisation the policy was trained with
  torch::manual_seed(static_cast<uint64_t>(config.trainer.seed));
  auto policy = models::makePolicy(config.model);
  models::ObservationEncoder encoder(config.model);
  encoder->loadPretrained();
  models::loadStateStrict(*policy, weights, checkpoint.string());
  const torch::Device device = models::modelDevice(config.model);
  policy->to(device);
  encoder->to(device);
  return std::make_unique<rollout::PolicyAgent>(
      policy, encoder, config.eval.num_envs, config.eval.sample_actions,
      static_cast<uint64_t>(config.eval.seed),
      config.dataset.max_instruction_length);
}

// an exported archive: a low-level policy, or a waypoint agent whose
// model, views and suppression come from the archive and whose panorama,
// candidates and execution come from `config` (waypoint_agent.*), as for
// the checkpoint it was exported from
std::unique_ptr<rollout::Agent> scriptedAgent(
    const train::ExperimentConfig& config, const fs::path& file) {
  const rollout::EvalConfig& ec = config.eval;
  const std::string who = "eval";
  torch::jit::Module module =
      rollout::loadExportedArchive(file, config.model.device, who);
  const torch::Device device = rollout::parseDevice(config.model.device, who);
  if (!rollout::isWaypointExport(module))
    return std::make_unique<rollout::ScriptedPolicyAgent>(
        std::move(module), file, ec.num_envs, ec.sample_actions,
        static_cast<uint64_t>(ec.seed), config.dataset.max_instruction_length,
        device);
  auto model = std::make_unique<rollout::ScriptedWaypointModel>(
      std::move(module), file, config.dataset.max_instruction_length, device);
  train::ExperimentConfig checked = config;
  checked.model = model->config();
  train::checkWaypointPanorama(checked, "eval of '" + file.string() + "'");
  VLN_CHECK_ARG(config.waypoint_agent.candidates != "predictor" ||
                    model->proposes(),
                "eval: '", file.string(),
                "' was exported without the candidate predictor; set "
                "waypoint_agent.candidates: depth_baseline to run it on the "
                "depth-only baseline's candidates");
  return std::make_unique<rollout::WaypointAgent>(
      std::move(model), config.waypoint_agent, config.panorama,
      config.sim.agent, ec.num_envs, ec.sample_actions,
      static_cast<uint64_t>(ec.seed));
}

// `ensemble`: more waypoint policies voting with a checkpoint's (--ensemble)
std::unique_ptr<rollout::Agent> makeAgent(
    const Candidate& candidate, const train::ExperimentConfig& config,
    const BaselineStatistics* baselineStats,
    std::span<const fs::path> ensemble) {
  const rollout::EvalConfig& ec = config.eval;
  if (candidate.baseline == "oracle")
    return makeOracleAgent(config.sim.agent, config.task, config.trainer.expert,
                           ec.num_envs);
  if (!candidate.baseline.empty()) {
    VLN_ASSERT(baselineStats != nullptr);
    return std::make_unique<BaselineAgentAdapter>(
        candidate.baseline, *baselineStats, ec.num_envs,
        static_cast<uint64_t>(ec.seed));
  }
  if (!candidate.scripted.empty())
    return scriptedAgent(config, candidate.scripted);
  return policyAgent(config, candidate.checkpoint, ensemble);
}

// an rxr_text policy reads the text feature files of the split it runs on
// (all checked before the first episode)
void useSplitTextFeatures(rollout::Agent& agent,
                          const train::ExperimentConfig& config,
                          const data::Split& split) {
  auto* policy = dynamic_cast<rollout::PolicyAgent*>(&agent);
  if (policy == nullptr || !config.model.usesInstruction() ||
      !config.model.usesTextFeatures())
    return;
  std::vector<const data::Episode*> episodes;
  for (const data::Episode& e : split.episodes) episodes.push_back(&e);
  const fs::path dir = config.dataset.textFeaturesPath();
  rollout::requireRxrTextFeatureFiles(dir, split.name, episodes);
  policy->setInstructionFeatures(rollout::rxrTextFeatureSource(
      dir, split.name, config.model.text_feature_dim));
}

// a waypoint agent with waypoint_agent.leg_words_only reads the clauses of
// the split it runs on
void useSplitLegWords(rollout::Agent& agent,
                      const train::ExperimentConfig& config,
                      const data::Split& split) {
  auto* waypoint = dynamic_cast<rollout::WaypointAgent*>(&agent);
  if (waypoint != nullptr) train::readSplitLegWords(*waypoint, config, split);
}

// ---------------------------------------------------------------------------
// one split

// nav-graphs by scan, read on first use, with their floor copies
class NavGraphs {
 public:
  struct Entry {
    data::NavGraph graph;
    data::NavGraph floor;
  };
  explicit NavGraphs(fs::path dir) : dir_(std::move(dir)) {}
  const Entry& of(const std::string& sceneId, rollout::SceneCache& scenes) {
    const std::string scan = data::sceneScanId(sceneId);
    auto it = graphs_.find(scan);
    if (it != graphs_.end()) return it->second;
    const fs::path file = dir_ / (scan + "_connectivity.json");
    VLN_CHECK_IO(fs::exists(file), "eval --navgraph: no nav-graph for scene '",
                 sceneId, "': '", file.string(), "' does not exist");
    Entry entry;
    entry.graph = data::readNavGraph(file);
    entry.floor = floorNavGraph(entry.graph, scenes.get(sceneId)->navmesh());
    return graphs_.emplace(scan, std::move(entry)).first->second;
  }

 private:
  fs::path dir_;
  std::map<std::string, Entry> graphs_;
};

struct SplitContext {
  const train::ExperimentConfig& config;
  const EvalCommandOptions& options;
  std::shared_ptr<rollout::SceneCache> scenes;
  fs::path outDir;
  NavGraphs* navgraphs = nullptr;
};

SplitReport evaluateSplit(rollout::Agent& agent, const Candidate& candidate,
                          const data::Split& split, const SplitContext& ctx) {
  const train::ExperimentConfig& c = ctx.config;

  // pictures of the first episodes, when asked for
  viz::PicturesConfig pictures;
  pictures.dir = ctx.outDir / "pictures";
  pictures.prefix =
      "ckpt_" + std::to_string(candidate.index) + "_" + split.name + "_";
  pictures.map_episodes = ctx.options.maps.value_or(c.eval.map_episodes);
  pictures.video_episodes = ctx.options.videos.value_or(c.eval.video_episodes);
  pictures.video_format = ctx.options.video_format;
  pictures.success_distance = c.task.success_distance;
  std::unique_ptr<viz::EpisodePictures> observer;
  if (pictures.map_episodes > 0 || pictures.video_episodes > 0)
    observer = std::make_unique<viz::EpisodePictures>(pictures);
  // observation dumps (--dump), watching beside the pictures
  const std::unique_ptr<viz::ObservationDump> dump =
      makeObservationDump(ctx.options.dump, split, c, candidate.label);

  // the HTML report, when asked for
  std::unique_ptr<viz::EpisodeReport> htmlReport;
  if (!ctx.options.report.empty()) {
    viz::ReportConfig rc;
    const std::string who = candidate.baseline.empty()
                                ? "ckpt_" + std::to_string(candidate.index)
                                : candidate.baseline;
    rc.dir = ctx.options.report / (who + "_" + split.name);
    rc.title = candidate.label + " on " + split.name;
    rc.detail_episodes = ctx.options.report_episodes;
    rc.success_distance = c.task.success_distance;
    rc.vocabulary = split.vocabulary ? &*split.vocabulary : nullptr;
    rc.max_instruction_length = c.dataset.max_instruction_length;
    htmlReport = std::make_unique<viz::EpisodeReport>(rc, &agent);
  }
  rollout::EpisodeObservers observers;
  observers.add(observer.get());
  observers.add(htmlReport.get());
  observers.add(dump.get());

  rollout::SplitEvaluationOptions options;
  options.checkpoint = candidate.index;
  options.label = candidate.label;
  options.out_dir = ctx.outDir;
  options.save_episodes = c.eval.save_episodes;
  options.predictions_of_scored = split.hiddenGoals;
  options.observer = observers.empty() ? nullptr : &observers;
  SplitReport report;
  static_cast<rollout::SplitEvaluation&>(report) = rollout::evaluateSplit(
      agent, split, ctx.scenes, c.sim, c.task, c.eval, options);

  // the nav-graph comparison (Table 3) of the scored episodes; the R2R
  // viewpoints on the floor are the episode's reference path (ground-truth
  // locations stop short of the last viewpoint)
  const rollout::EvaluationResult& result = report.result;
  if (ctx.navgraphs != nullptr && report.scored) {
    std::vector<GraphEpisodeMetrics> graphMetrics;
    for (size_t i = 0; i < result.episodes.size(); ++i) {
      if (!result.scored[i]) continue;
      const data::Episode& episode = split.episodes[i];
      const rollout::EpisodeRecord& record = result.episodes[i].record;
      const std::vector<Vec3f>& reference = episode.reference_path.empty()
                                                ? record.reference_path
                                                : episode.reference_path;
      const NavGraphs::Entry& graphs =
          ctx.navgraphs->of(episode.scene_id, *ctx.scenes);
      graphMetrics.push_back(scoreOnNavGraph(graphs.graph, graphs.floor,
                                             record.positions, reference,
                                             record.episode_id));
    }
    report.graph = aggregateGraph(graphMetrics);
    report.files.push_back(writeGraphStatsFile(ctx.outDir, candidate.index,
                                               split.name, *report.graph));
  }
  if (observer)
    for (const auto& file : observer->files()) report.files.push_back(file);
  if (dump)
    for (const auto& folder : dump->folders()) report.files.push_back(folder);
  if (htmlReport) report.files.push_back(htmlReport->write());
  return report;
}

std::string graphText(const GraphSplitStats& g) {
  char text[160];
  std::snprintf(text, sizeof(text),
                "TL %.2f NE %.2f OS %.3f SR %.3f SPL %.3f (%d episodes)",
                g.mean.path_length, g.mean.distance_to_goal,
                g.mean.oracle_success, g.mean.success, g.mean.spl,
                g.num_episodes);
  return text;
}

}  // namespace

// ---------------------------------------------------------------------------
// public

std::string summaryLine(const SplitReport& report) {
  std::string line = rollout::summaryLine(report);
  if (report.graph) line += " | nav-graph " + graphText(*report.graph);
  return line;
}

EvalCommandResult runEvaluation(const EvalCommandOptions& options,
                                const train::ExperimentConfig& settings,
                                std::ostream& out) {
  // threads before any model is built
  common::setBlasThreadsEnv(settings.trainer.torch_threads);
  torch::set_num_threads(settings.trainer.torch_threads);

  const fs::path outDir = options.out.empty()
                              ? fs::path(settings.output.dir) / "eval"
                              : options.out;
  std::vector<std::string> splitNames =
      options.splits.empty() ? settings.eval.splits : options.splits;
  VLN_CHECK_ARG(!splitNames.empty(),
                "eval: no split to evaluate (eval.splits "
                "is empty and no --split was given)");
  VLN_CHECK_ARG(options.video_format == "avi" || options.video_format == "mp4",
                "eval: --video-format must be avi or mp4, got '",
                options.video_format, "'");
  VLN_CHECK_ARG(options.report_episodes >= 0,
                "eval: --report-episodes must be >= 0, got ",
                options.report_episodes);
  // the split published without goals: R2R's test, RxR's test_challenge
  const std::string heldOut =
      settings.dataset.isRxr() ? "test_challenge" : "test";
  VLN_CHECK_ARG(options.test_ground_truth.empty() ||
                    std::find(splitNames.begin(), splitNames.end(), heldOut) !=
                        splitNames.end(),
                "eval: --test-ground-truth '",
                options.test_ground_truth.string(), "' scores the split '",
                heldOut, "', which is not evaluated (add --split ", heldOut,
                ")");
  const int cap = options.episodes.value_or(settings.eval.episodes);
  VLN_CHECK_ARG(cap == -1 || cap >= 1,
                "eval: --episodes must be >= 1 (or -1 "
                "for all), got ",
                cap);

  // what to evaluate
  std::vector<Candidate> candidates;
  bool directoryMode = false;
  std::unique_ptr<BaselineStatistics> baselineStats;
  if (options.agent == "oracle" && options.checkpoint.empty()) {
    out << "oracle: trainer.expert " << settings.trainer.expert
        << ", stopping within task.follower_goal_radius "
        << settings.task.follower_goal_radius << " m\n";
    candidates.push_back(
        {options.index.value_or(0), "oracle", {}, {}, options.agent});
  } else if (!options.agent.empty()) {
    VLN_CHECK_ARG(options.checkpoint.empty(),
                  "eval: give either --checkpoint "
                  "or --agent, not both (got --checkpoint '",
                  options.checkpoint.string(), "' and --agent '", options.agent,
                  "')");
    VLN_CHECK_ARG(options.agent == "random" || options.agent == "handcrafted",
                  "eval: --agent must be random, handcrafted or oracle, got '",
                  options.agent, "'");
    // R2R: <train_split>_gt.json.gz; RxR: the filter's roles' files merged
    const data::DatasetConfig& dataset = settings.dataset;
    const std::vector<fs::path> gtFiles =
        data::datasetGroundTruthPaths(dataset, dataset.train_split);
    for (const fs::path& gt : gtFiles)
      VLN_CHECK_IO(fs::exists(gt), "eval --agent ", options.agent,
                   ": the baseline's statistics need the ground truth of "
                   "dataset.train_split '",
                   dataset.train_split, "': '", gt.string(),
                   "' does not exist");
    const data::GroundTruth truth =
        dataset.isRxr()
            ? data::readRxrGroundTruth(dataset.data_path, dataset.train_split,
                                       dataset.rxr_filter.resolvedRoles())
            : data::readGroundTruth(gtFiles.front());
    baselineStats = std::make_unique<BaselineStatistics>(baselineStatistics(
        truth, settings.sim.agent, gtFiles.front().string()));
    out << "baseline " << options.agent << ": " << baselineStats->num_paths
        << " training paths, mean length " << baselineStats->mean_path_length
        << " m (" << baselineStats->forward_steps << " forward steps, up to "
        << baselineStats->max_turns << " turns), actions "
        << "STOP " << baselineStats->distribution[0] << " FORWARD "
        << baselineStats->distribution[1] << " LEFT "
        << baselineStats->distribution[2] << " RIGHT "
        << baselineStats->distribution[3] << "\n";
    candidates.push_back(
        {options.index.value_or(0), options.agent, {}, {}, options.agent});
  } else {
    VLN_CHECK_ARG(!options.checkpoint.empty(),
                  "eval: give --checkpoint (a ckpt.<i>.pth file, a directory "
                  "of them or a .pt export) or --agent");
    const fs::path& path = options.checkpoint;
    VLN_CHECK_IO(fs::exists(path), "eval: --checkpoint '", path.string(),
                 "' does not exist");
    if (fs::is_directory(path)) {
      directoryMode = true;
      const auto files = train::listCheckpoints(path);
      VLN_CHECK_IO(!files.empty(), "eval: --checkpoint directory '",
                   path.string(), "' holds no ckpt.<i>.pth");
      for (const auto& file : files) {
        const std::optional<int> index = train::checkpointIndex(file);
        VLN_ASSERT(index.has_value());
        candidates.push_back({*index, file.filename().string(), file, {}, {}});
      }
    } else {
      const std::optional<int> parsed = train::checkpointIndex(path);
      const int index = options.index.value_or(parsed.value_or(0));
      if (path.extension() == ".pt") {
        candidates.push_back({index, path.filename().string(), {}, path, {}});
      } else {
        candidates.push_back({index, path.filename().string(), path, {}, {}});
      }
    }
  }
  std::vector<fs::path> ensemble;  // the members' checkpoint files
  if (!options.ensemble.empty()) {
    VLN_CHECK_ARG(settings.trainer.task == "waypoint_cma",
                  "eval --ensemble: only waypoint agents (trainer.task "
                  "waypoint_cma) are ensembled; this config's task is '",
                  settings.trainer.task, "'");
    VLN_CHECK_ARG(candidates.size() == 1 && !directoryMode &&
                      !candidates.front().checkpoint.empty(),
                  "eval --ensemble: --checkpoint must be one checkpoint "
                  "file (ckpt.<i>.pth), not a directory, an export or a "
                  "baseline");
    for (const fs::path& member : options.ensemble) {
      VLN_CHECK_IO(fs::exists(member), "eval --ensemble: '", member.string(),
                   "' does not exist");
      // a run directory: its best checkpoint (else its newest)
      ensemble.push_back(fs::is_directory(member)
                             ? train::bestOrLatestCheckpoint(member)
                             : member);
    }
    Candidate& first = candidates.front();
    first.label +=
        " + " + std::to_string(ensemble.size()) + " ensemble member(s)";
    out << "ensemble: " << first.checkpoint.string();
    for (const fs::path& member : ensemble) out << ", " << member.string();
    out << " (choice probabilities averaged)\n";
  }

  // the splits, loaded once; the test split with its hidden goals when given
  std::vector<data::Split> splits;
  for (const auto& name : splitNames)
    splits.push_back(loadSplit(settings, name, cap));
  if (!options.test_ground_truth.empty()) {
    const auto test = std::find_if(
        splits.begin(), splits.end(),
        [&](const data::Split& s) { return s.name == heldOut; });
    VLN_ASSERT(test != splits.end());  // checked with the options
    attachTestGroundTruth(*test, options.test_ground_truth, settings.dataset,
                          out);
  }
  // after the hidden goals: the oracle can walk a test split that has them
  if (options.agent == "oracle") checkOracleSplits(splits);
  checkDumpOptions(options.dump, splits, candidates.size(), settings);

  std::unique_ptr<NavGraphs> navgraphs;
  if (!options.navgraph.empty()) {
    VLN_CHECK_IO(fs::is_directory(options.navgraph), "eval: --navgraph '",
                 options.navgraph.string(), "' is not a directory");
    navgraphs = std::make_unique<NavGraphs>(options.navgraph);
  }
  const SplitContext ctx{settings, options,
                         std::make_shared<rollout::SceneCache>(settings.sim),
                         outDir, navgraphs.get()};
  fs::create_directories(outDir);

  EvalCommandResult result;
  for (const Candidate& candidate : candidates) {
    // a directory's checkpoints that were already evaluated are skipped
    // split by split (the trainer writes the same files into <run>/eval)
    std::vector<const data::Split*> todo;
    for (const data::Split& split : splits) {
      const fs::path done =
          outDir /
          (split.hasGoals
               ? rollout::statsFileName(candidate.index, split.name)
               : rollout::predictionsFileName(candidate.index, split.name));
      if (directoryMode && fs::exists(done)) {
        SplitReport skipped;
        skipped.checkpoint = candidate.index;
        skipped.split = split.name;
        skipped.skipped = true;
        skipped.scored = split.hasGoals;
        if (split.hasGoals) skipped.stats = rollout::readStatsFile(done);
        out << summaryLine(skipped) << "\n";
        result.reports.push_back(std::move(skipped));
        continue;
      }
      todo.push_back(&split);
    }
    if (todo.empty()) continue;
    const std::unique_ptr<rollout::Agent> agent =
        makeAgent(candidate, settings, baselineStats.get(), ensemble);
    if (!options.report.empty()) agent->keepInstructionAttention(true);
    for (const data::Split* split : todo) {
      useSplitTextFeatures(*agent, settings, *split);
      useSplitLegWords(*agent, settings, *split);
      SplitReport report = evaluateSplit(*agent, candidate, *split, ctx);
      out << summaryLine(report) << "\n";
      out.flush();
      result.reports.push_back(std::move(report));
    }
  }

  if (!options.report.empty()) {
    const fs::path index = viz::writeReportIndex(options.report);
    out << "report: " << index.string() << "\n";
  }

  // the best checkpoint of a directory by the selection split's SPL, read
  // back from the stats files so skipped checkpoints count too
  if (directoryMode) {
    const std::string& selection = settings.eval.selection_split;
    for (const Candidate& candidate : candidates) {
      const fs::path file =
          outDir / rollout::statsFileName(candidate.index, selection);
      if (!fs::exists(file)) continue;
      const double spl = rollout::readStatsFile(file).mean.spl;
      if (!result.best_checkpoint || spl > result.best_spl) {
        result.best_checkpoint = candidate.index;
        result.best_spl = spl;
      }
    }
    if (result.best_checkpoint) {
      const Candidate& best = *std::find_if(
          candidates.begin(), candidates.end(), [&](const Candidate& c) {
            return c.index == *result.best_checkpoint;
          });
      common::writeJsonFile(
          outDir / "best.json",
          {{"checkpoint", best.checkpoint.filename().string()},
           {"index", best.index},
           {"split", selection},
           {"spl", result.best_spl}},
          2);
      char spl[32];
      std::snprintf(spl, sizeof(spl), "%.4f", result.best_spl);
      out << "best checkpoint: " << best.checkpoint.filename().string() << " ("
          << selection << " SPL " << spl << "), written to "
          << (outDir / "best.json").string() << "\n";
    } else {
      out << "best checkpoint: none (no stats for eval.selection_split '"
          << selection << "'; evaluate that split to select one)\n";
    }
  }
  return result;
}

int runEvalCommand(const EvalCommandOptions& options,
                   const train::ExperimentConfig& config, std::ostream& out) {
  runEvaluation(options, config, out);
  return 0;
}

int runTablesCommand(const TablesCommandOptions& options, std::ostream& out) {
  VLN_CHECK_ARG(!options.runs.empty(), "eval tables: --runs is required");
  VLN_CHECK_ARG(!options.out.empty(), "eval tables: --out is required");
  std::vector<BuiltTable> tables = buildTables(options.runs);
  if (options.claimed_only) tables = claimedRowsOnly(std::move(tables));
  const auto [markdown, latex] =
      writeTables(tables, options.out,
                  "eval tables --runs " + options.runs.string() +
                      (options.claimed_only ? " --claimed-only" : ""));
  int ours = 0;
  for (const auto& table : tables)
    for (const auto& row : table.rows)
      if (row.ours) ++ours;
  out << "wrote " << markdown.string() << " and " << latex.string() << " ("
      << tables.size() << " tables, " << ours << " rows of ours)\n";
  return 0;
}

int runCurveCommand(const CurveCommandOptions& options, std::ostream& out) {
  VLN_CHECK_ARG(!options.run.empty(), "eval curve: --run is required");
  VLN_CHECK_ARG(!options.out.empty(), "eval curve: --out is required");
  const fs::path metrics = options.run / "metrics.jsonl";
  VLN_CHECK_IO(fs::exists(metrics), "eval curve: '", metrics.string(),
               "' does not exist (is --run '", options.run.string(),
               "' a training run's output.dir?)");
  viz::CurveStyle style;
  style.title = options.title;
  if (style.title.empty()) {
    // the run's folder name, with its parent's for runs/<name>/seed<S>
    fs::path run = options.run.lexically_normal();
    if (run.filename().empty()) run = run.parent_path();  // a trailing '/'
    std::string name = run.filename().string();
    if (name.starts_with("seed"))
      name = run.parent_path().filename().string() + "/" + name;
    style.title = options.split + " learning curve: " + name;
  }
  const viz::LearningCurve curve =
      viz::saveLearningCurve(metrics, options.out, options.split, style);
  const auto best =
      std::max_element(curve.points.begin(), curve.points.end(),
                       [](const viz::CurvePoint& a, const viz::CurvePoint& b) {
                         return a.spl < b.spl;
                       });
  char line[160];
  std::snprintf(line, sizeof(line),
                "best SPL %.3f (SR %.3f) at ckpt %d, %lld updates, %.1f min",
                best->spl, best->success, best->checkpoint,
                static_cast<long long>(best->updates), best->seconds / 60.0);
  out << "wrote " << options.out.string() << " (" << curve.points.size()
      << (curve.points.size() == 1 ? " validation" : " validations") << " of "
      << options.split << "; " << line << ")\n";
  return 0;
}

int runCompareCommand(const CompareCommandOptions& options, std::ostream& out) {
  VLN_CHECK_ARG(!options.runs.empty(), "eval compare: --runs is required");
  VLN_CHECK_ARG(!options.out.empty(), "eval compare: --out is required");
  const auto judgements =
      judgeFindings(buildTables(options.runs), paperFindings(), kFindingSplit,
                    kFindingMetrics);
  common::writeFileAtomic(
      options.out, "<!-- Generated by `eval compare --runs " +
                       options.runs.string() + "`. -->\n\n" +
                       renderFindingsMarkdown(judgements, kFindingSplit));
  auto counts = countVerdicts(judgements);
  out << "wrote " << options.out.string() << " (" << judgements.size()
      << " findings x " << kFindingMetrics.size()
      << " metrics: " << counts[Verdict::kHolds] << " hold, "
      << counts[Verdict::kDoesNotHold] << " do not hold, "
      << counts[Verdict::kCannotTell] << " cannot tell)\n";
  return 0;
}

}  // namespace vln::eval
