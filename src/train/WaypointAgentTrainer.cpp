#include "train/WaypointAgentTrainer.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <limits>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "common/Check.h"
#include "common/Progress.h"
#include "common/Random.h"
#include "models/Loss.h"
#include "models/StateDict.h"
#include "rollout/EpisodeScheduler.h"
#include "rollout/ObservationBatch.h"
#include "train/Checkpoint.h"
#include "train/CheckpointKeeper.h"
#include "train/Collector.h"
#include "train/MetricsLog.h"
#include "train/PeriodicEvaluator.h"
#include "train/TrainingData.h"
#include "train/TrainingSchedule.h"
#include "train/WaypointPretrainer.h"
#include "world/ViewLabels.h"

namespace vln::train {
namespace fs = std::filesystem;
namespace {

constexpr const char* kTask = "waypoint_cma";

int64_t flatSize(const models::FeatureShape& shape) {
  return shape[0] * shape[1] * shape[2];
}

// one episode's decisions and its instruction
struct CollectedEpisode {
  const data::Episode* episode = nullptr;
  std::vector<rollout::WaypointDecision> decisions;
};

// a collection round: the agent runs the episodes and hands over what it
// recorded, in the order the episodes end
class DecisionCollection : public rollout::EpisodeJob {
 public:
  DecisionCollection(std::span<const data::Episode* const> episodes,
                     rollout::WaypointAgent& agent, rollout::VectorEnv& envs,
                     std::vector<CollectedEpisode>& out)
      : episodes_(episodes), agent_(agent), envs_(envs), out_(out) {}
  /// Episodes that ended within their goal's radius.
  int64_t successes() const { return successes_; }
  rollout::EpisodeStart startOf(int index) override {
    return rollout::EpisodeStart::of(*episodes_[static_cast<size_t>(index)]);
  }
  void started(const rollout::EnvBatch& batch) override {
    for (size_t k = 0; k < batch.size(); ++k)
      agent_.reset(batch.envs[k],
                   *episodes_[static_cast<size_t>(batch.episodes[k])]);
  }
  std::vector<sim::Action> act(const rollout::EnvBatch& running) override {
    return agent_.act(envs_, running.envs);
  }
  void finished(const rollout::EnvBatch& ended) override {
    for (size_t k = 0; k < ended.size(); ++k) {
      CollectedEpisode e;
      e.episode = episodes_[static_cast<size_t>(ended.episodes[k])];
      // how far from the goal the round's driver (oracle and policy) ends
      const float distance =
          envs_.simulator(ended.envs[k])
              .scene()
              .navmesh()
              .geodesicDistance(envs_.state(ended.envs[k]).agent.position,
                                e.episode->goals.front().position);
      if (distance <= e.episode->goals.front().radius) ++successes_;
      e.decisions = agent_.takeDecisions(ended.envs[k]);
      if (!e.decisions.empty()) out_.push_back(std::move(e));
    }
  }

 private:
  std::span<const data::Episode* const> episodes_;
  rollout::WaypointAgent& agent_;
  rollout::VectorEnv& envs_;
  std::vector<CollectedEpisode>& out_;
  int64_t successes_ = 0;
};

// the token ids a mirrored replay exchanges
struct MirrorTokens {
  int64_t left = -1;
  int64_t right = -1;
};

// the ids of "left" and "right" in the train split's vocabulary (none
// needed without the instruction); throws std::invalid_argument naming
// waypoint_agent.mirror_probability when the split cannot say them
MirrorTokens mirrorTokensOf(const ExperimentConfig& config,
                            const TrainingData& data) {
  if (!config.model.usesInstruction()) return {};
  const std::string option = "waypoint_agent.mirror_probability";
  VLN_CHECK_ARG(data.train.vocabulary.has_value(), kTask, ": ", option,
                " needs the train split's instruction_vocab (what the tokens "
                "mean), and dataset.train_split has none");
  const auto left = data.train.vocabulary->find("left");
  const auto right = data.train.vocabulary->find("right");
  VLN_CHECK_ARG(left && right, kTask, ": ", option,
                " needs the words 'left' and 'right' in the train split's "
                "instruction_vocab");
  return {*left, *right};
}

}  // namespace

torch::Tensor acceptedSetLoss(const torch::Tensor& logits,
                              const torch::Tensor& labels,
                              const torch::Tensor& acceptable) {
  VLN_CHECK_ARG(logits.dim() == 2 && labels.dim() == 1 &&
                    acceptable.sizes() == logits.sizes() &&
                    labels.size(0) == logits.size(0),
                "acceptedSetLoss(): logits [D, C], labels [D] and acceptable "
                "[D, C] expected, got ",
                logits.sizes(), ", ", labels.sizes(), " and ",
                acceptable.sizes());
  const torch::Tensor valid = labels.ge(0);
  if (!valid.any().item<bool>()) return logits.sum() * 0.0;
  // the label alone everywhere: the cross-entropy itself, so that runs
  // without waypoint_agent.label_tolerance train the same bits as before
  if (acceptable.sum(1).le(1).all().item<bool>())
    return torch::nn::functional::cross_entropy(
        logits, labels,
        torch::nn::functional::CrossEntropyFuncOptions().ignore_index(-1));
  const torch::Tensor rows = logits.index({valid});
  const torch::Tensor accepted = acceptable.index({valid});
  const torch::Tensor all = torch::logsumexp(rows, 1);
  const torch::Tensor kept = torch::logsumexp(
      rows.masked_fill(accepted.logical_not(),
                       -std::numeric_limits<float>::infinity()),
      1);
  return (all - kept).mean();
}

torch::Tensor instructionContrastLoss(
    models::WaypointCmaPolicyImpl& policy,
    const models::WaypointPolicyInputs& inputs, const torch::Tensor& logits,
    const torch::Tensor& labels,
    const std::vector<const data::Episode*>& instructions, int maxLength,
    const torch::Device& device) {
  std::vector<const data::Episode*> others(instructions.size());
  for (size_t i = 0; i < instructions.size(); ++i)
    others[i] = instructions[(i + 1) % instructions.size()];
  const models::EncodedInstruction swapped = policy.encodeInstruction(
      rollout::batchInstructions(others, maxLength).to(device));
  const torch::Tensor swappedLogits =
      policy
          .forwardSequence(swapped, inputs,
                           policy.initialHidden(
                               static_cast<int64_t>(instructions.size())))
          .logits.reshape({labels.size(0), -1});
  return models::instructionContrast(logits, swappedLogits, labels,
                                     labels.ge(0));
}

SubInstructionTokensByEpisode loadEpisodeClauses(
    const ExperimentConfig& config, std::span<const data::Split* const> splits,
    std::string_view option) {
  SubInstructionTokensByEpisode out;
  for (const data::Split* split : splits) {
    const fs::path file =
        data::splitSubInstructionsPath(config.dataset.data_path, split->name);
    VLN_CHECK_ARG(fs::exists(file), kTask, ": ", option, " needs '",
                  file.string(),
                  "', which does not exist (vlnce-data generate writes it for "
                  "the training splits of a generated world, and for its "
                  "evaluation splits with "
                  "splits.evaluation_sub_instructions)");
    const data::SubInstructions subs = data::readSubInstructions(file);
    data::checkSubInstructions(subs, split->episodes,
                               strCat(option, ": '", file.string(), "'"));
    for (const data::Episode& e : split->episodes)
      out[&e] = data::subInstructionTokens(e.instruction.instruction_text,
                                           subs.at(e.episode_id));
  }
  return out;
}

SubInstructionTokensByEpisode loadSubInstructionTokens(
    const ExperimentConfig& config, const TrainingData& data) {
  std::vector<const data::Split*> splits{&data.train};
  if (data.aug) splits.push_back(data.aug.get());
  for (const auto& extra : data.extra) splits.push_back(extra.get());
  return loadEpisodeClauses(config, splits,
                            config.waypoint_agent.sub_instruction_weight > 0.0
                                ? "waypoint_agent.sub_instruction_weight"
                            : config.waypoint_agent.leg_words_only
                                ? "waypoint_agent.leg_words_only"
                                : "model.clause_tracker");
}

void readSplitLegWords(rollout::WaypointAgent& agent,
                       const ExperimentConfig& config,
                       const data::Split& split) {
  if (!config.waypoint_agent.leg_words_only) return;
  const data::Split* splits[] = {&split};
  agent.readLegWordsOnly(
      loadEpisodeClauses(config, splits, "waypoint_agent.leg_words_only"),
      config.dataset.max_instruction_length);
}

at::Tensor subInstructionTargets(
    std::span<const std::vector<rollout::WaypointDecision>* const> rows,
    std::span<const data::Episode* const> episodes,
    const SubInstructionTokensByEpisode& tokens, int64_t L) {
  VLN_CHECK_ARG(rows.size() == episodes.size(),
                "subInstructionTargets(): ", rows.size(), " rows for ",
                episodes.size(), " episodes");
  int64_t T = 0;
  for (const auto* row : rows) T = std::max<int64_t>(T, row->size());
  const auto B = static_cast<int64_t>(rows.size());
  at::Tensor targets = torch::zeros({T, B, L});
  auto access = targets.accessor<float, 3>();
  for (int64_t b = 0; b < B; ++b) {
    const data::Episode& episode = *episodes[static_cast<size_t>(b)];
    const auto it = tokens.find(&episode);
    if (it == tokens.end() || episode.reference_path.size() < 2) continue;
    const auto& clauses = it->second;
    const auto& row = *rows[static_cast<size_t>(b)];
    for (size_t t = 0; t < row.size(); ++t)
      for (const data::SubInstructionTokens& c :
           data::clausesAhead(clauses, episode.reference_path, row[t].position))
        for (int k = c.first; k < std::min<int64_t>(c.last, L); ++k)
          access[static_cast<int64_t>(t)][b][k] = 1.0f;
  }
  return targets;
}

at::Tensor clauseTargets(
    std::span<const std::vector<rollout::WaypointDecision>* const> rows,
    std::span<const data::Episode* const> episodes,
    const SubInstructionTokensByEpisode& tokens) {
  VLN_CHECK_ARG(rows.size() == episodes.size(),
                "clauseTargets(): ", rows.size(), " rows for ", episodes.size(),
                " episodes");
  int64_t T = 0;
  for (const auto* row : rows) T = std::max<int64_t>(T, row->size());
  const auto B = static_cast<int64_t>(rows.size());
  at::Tensor targets = torch::full({T, B}, -1, torch::kInt64);
  auto access = targets.accessor<int64_t, 2>();
  for (int64_t b = 0; b < B; ++b) {
    const data::Episode& episode = *episodes[static_cast<size_t>(b)];
    const auto it = tokens.find(&episode);
    VLN_CHECK_ARG(it != tokens.end(), "clauseTargets(): episode ",
                  episode.episode_id, " has no sub-instructions");
    const std::vector<data::SubInstructionTokens> rule =
        data::ruleClauses(episode.instruction.instruction_text);
    const int last = std::max(0, static_cast<int>(rule.size()) - 1);
    const auto& row = *rows[static_cast<size_t>(b)];
    for (size_t t = 0; t < row.size(); ++t) {
      const std::vector<data::SubInstructionTokens> ahead = data::clausesAhead(
          it->second, episode.reference_path, row[t].position);
      access[static_cast<int64_t>(t)][b] =
          ahead.empty() ? last : data::clauseHolding(rule, ahead.front().first);
    }
  }
  return targets;
}

at::Tensor progressTargets(
    std::span<const std::vector<rollout::WaypointDecision>* const> rows,
    std::span<const data::Episode* const> episodes, bool clip) {
  VLN_CHECK_ARG(rows.size() == episodes.size(),
                "progressTargets(): ", rows.size(), " rows for ",
                episodes.size(), " episodes");
  size_t steps = 0;
  for (const auto* row : rows) steps = std::max(steps, row->size());
  at::Tensor targets = torch::zeros(
      {static_cast<int64_t>(steps), static_cast<int64_t>(rows.size())});
  auto t = targets.accessor<float, 2>();
  for (size_t b = 0; b < rows.size(); ++b) {
    const float start = episodes[b]->geodesic_distance.value_or(
        std::numeric_limits<float>::infinity());
    for (size_t s = 0; s < rows[b]->size(); ++s)
      t[static_cast<int64_t>(s)][static_cast<int64_t>(b)] =
          progressTarget(start, (*rows[b])[s].goal_distance, clip);
  }
  return targets;
}

torch::Tensor subInstructionLoss(const torch::Tensor& attention,
                                 const torch::Tensor& targets) {
  VLN_CHECK_ARG(attention.sizes() == targets.sizes(),
                "subInstructionLoss(): attention ", attention.sizes(),
                " and targets ", targets.sizes(), " differ");
  const torch::Tensor mass = (attention * targets).sum(-1);
  const torch::Tensor has = targets.sum(-1).gt(0);
  if (!has.any().item<bool>()) return attention.sum() * 0.0;
  // the floor keeps log finite where the attention is exactly 0
  return -torch::log(mass.masked_select(has).clamp_min(1e-8)).mean();
}

void validateWaypointAgentConfig(const ExperimentConfig& config) {
  checkWaypointPanorama(config, kTask);
  if (config.waypoint_agent.candidates == "predictor")
    models::checkPredictorInputs(config.model, config.waypoint.predictor,
                                 kTask);
  VLN_CHECK_ARG(!config.model.usesTextFeatures(), kTask,
                ": model.instruction_features must be tokens");
  VLN_CHECK_ARG(config.trainer.instruction_contrast_weight == 0.0 ||
                    config.model.usesInstruction(),
                kTask,
                ": trainer.instruction_contrast_weight needs the instruction "
                "(model.no_instruction is true)");
  VLN_CHECK_ARG(config.waypoint_agent.sub_instruction_weight == 0.0 ||
                    config.model.usesInstruction(),
                kTask,
                ": waypoint_agent.sub_instruction_weight needs the instruction "
                "(model.no_instruction is true)");
  VLN_CHECK_ARG(config.waypoint_agent.sub_instruction_weight == 0.0 ||
                    !config.dataset.isRxr(),
                kTask,
                ": waypoint_agent.sub_instruction_weight needs R2R-format "
                "training splits with sub-instruction files (dataset.format "
                "is rxr)");
  VLN_CHECK_ARG(!config.waypoint_agent.leg_words_only ||
                    (config.model.usesInstruction() && !config.dataset.isRxr()),
                kTask,
                ": waypoint_agent.leg_words_only needs the instruction and "
                "R2R-format splits with sub-instruction files (no_instruction ",
                config.model.no_instruction, ", dataset.format ",
                config.dataset.format, ")");
  VLN_CHECK_ARG(!config.waypoint_agent.leg_words_only ||
                    config.trainer.instruction_contrast_weight == 0.0,
                kTask,
                ": waypoint_agent.leg_words_only and "
                "trainer.instruction_contrast_weight cannot be combined (the "
                "leg's words are another instruction's tokens)");
  VLN_CHECK_ARG(
      !config.model.clause_tracker ||
          (!config.dataset.isRxr() && !config.waypoint_agent.leg_words_only &&
           config.trainer.instruction_contrast_weight == 0.0),
      kTask,
      ": model.clause_tracker needs R2R-format training splits with "
      "sub-instruction files, and chooses the words itself: it "
      "cannot be combined with waypoint_agent.leg_words_only or "
      "trainer.instruction_contrast_weight (dataset.format ",
      config.dataset.format, ", leg_words_only ",
      config.waypoint_agent.leg_words_only, ", instruction_contrast_weight ",
      config.trainer.instruction_contrast_weight, ")");
  VLN_CHECK_ARG(
      !config.model.goal_match ||
          (config.model.rgb_semantic_outputs == world::viewLabelSize() &&
           config.trainer.instruction_contrast_weight == 0.0),
      kTask, ": model.goal_match reads the RGB features as the ",
      world::viewLabelSize(), " view labels (model.rgb_semantic_outputs, got ",
      config.model.rgb_semantic_outputs,
      ") and cannot be combined with "
      "trainer.instruction_contrast_weight (got ",
      config.trainer.instruction_contrast_weight, ")");
  if (config.waypoint_agent.view_labels) {
    VLN_CHECK_ARG(config.model.usesRgb() && config.model.rgb_semantic_outputs ==
                                                world::viewLabelSize(),
                  kTask,
                  ": waypoint_agent.view_labels takes the place of the RGB "
                  "features: it needs model.no_rgb false and "
                  "model.rgb_semantic_outputs ",
                  world::viewLabelSize(), " (got no_rgb ", config.model.no_rgb,
                  ", rgb_semantic_outputs ", config.model.rgb_semantic_outputs,
                  ")");
  }
  VLN_CHECK_ARG(config.trainer.mode == "dagger", kTask,
                ": trainer.mode must be dagger (the agent's rounds are "
                "collected by the waypoint oracle)");
  VLN_CHECK_ARG(config.waypoint_agent.mirror_probability == 0.0 ||
                    config.trainer.instruction_contrast_weight == 0.0,
                kTask,
                ": waypoint_agent.mirror_probability and "
                "trainer.instruction_contrast_weight cannot be combined (the "
                "contrast would read the unmirrored words)");
  VLN_CHECK_ARG(config.waypoint_agent.label_tolerance == 0.0 ||
                    config.waypoint_agent.max_candidates <= 31,
                kTask,
                ": waypoint_agent.label_tolerance needs max_candidates <= 31 "
                "(got ",
                config.waypoint_agent.max_candidates, ")");
  if (config.waypoint_agent.candidates == "predictor") {
    config.waypoint.predictor.validate("waypoint.predictor");
    VLN_CHECK_ARG(!config.waypoint_agent.predictor_weights.empty(), kTask,
                  ": waypoint_agent.predictor_weights is empty (train one "
                  "with configs/waypoint/predictor.yaml, or set "
                  "waypoint_agent.candidates: depth_baseline)");
  }
}

namespace {

// an initialised waypoint CMA of config.model on the config's panorama
std::shared_ptr<models::WaypointCmaPolicyImpl> newWaypointPolicy(
    const ExperimentConfig& config) {
  const models::ModelConfig& m = config.model;
  return std::make_shared<models::WaypointCmaPolicyImpl>(
      m, config.panorama.num_views,
      m.usesRgb() ? flatSize(models::rgbFeatureShape(m)) : 0,
      m.usesDepth() ? flatSize(models::depthFeatureShape(m)) : 0);
}

}  // namespace

WaypointAgentModels makeWaypointAgentModels(const ExperimentConfig& config,
                                            bool withEmbeddings) {
  const models::ModelConfig& m = config.model;
  torch::manual_seed(static_cast<uint64_t>(config.trainer.seed));
  WaypointAgentModels out;
  out.policy = newWaypointPolicy(config);
  if (withEmbeddings && m.usesInstruction())
    out.policy->setWordEmbeddings(embeddingTensor(config));
  // with view_labels the policy's RGB features are the views' labels: no
  // RGB encoder runs (or needs weights)
  models::ModelConfig encoderConfig = m;
  if (config.waypoint_agent.view_labels) {
    encoderConfig.no_rgb = true;
    encoderConfig.goal_match = false;  // the policy's, over the labels
  }
  out.encoder = models::ObservationEncoder(encoderConfig);
  out.encoder->loadPretrained();
  if (config.waypoint_agent.candidates == "predictor") {
    const fs::path file = config.waypoint_agent.predictor_weights;
    VLN_CHECK_IO(fs::exists(file), kTask,
                 ": waypoint_agent.predictor_weights '", file.string(),
                 "' does not exist (train it with configs/waypoint/"
                 "predictor.yaml)");
    out.predictor = models::makeWaypointPredictor(m, config.waypoint.predictor,
                                                  config.panorama.num_views);
    models::loadModule(*out.predictor, file);
    out.predictor->eval();
  }
  const torch::Device device = models::modelDevice(m);
  out.policy->to(device);
  out.encoder->to(device);
  if (!out.predictor.is_empty()) out.predictor->to(device);
  return out;
}

void addEnsembleMembers(WaypointAgentModels& models,
                        const ExperimentConfig& config,
                        std::span<const fs::path> checkpoints) {
  const torch::Device device = models::modelDevice(config.model);
  for (const fs::path& given : checkpoints) {
    std::shared_ptr<models::WaypointCmaPolicyImpl> member =
        newWaypointPolicy(config);
    models::loadStateStrict(*member, readPolicyWeights(given), given.string());
    member->to(device);
    member->eval();
    models.ensemble.push_back(std::move(member));
  }
}

std::unique_ptr<rollout::WaypointAgent> makeWaypointAgent(
    const ExperimentConfig& config, const WaypointAgentModels& models,
    int numEnvs, bool sampleActions, uint64_t seed) {
  const WaypointPretrainConfig& w = config.waypoint;
  rollout::CandidateNms nms;
  nms.max_candidates = w.nms_max_candidates;
  nms.heading_radius = w.nms_heading_radius;
  nms.distance_radius = w.nms_distance_radius;
  nms.min_score = static_cast<float>(w.nms_min_score);
  std::vector<std::shared_ptr<models::WaypointCmaPolicyImpl>> policies{
      models.policy};
  policies.insert(policies.end(), models.ensemble.begin(),
                  models.ensemble.end());
  return std::make_unique<rollout::WaypointAgent>(
      std::make_unique<rollout::NativeWaypointModel>(
          std::move(policies), models.encoder, models.predictor, nms,
          config.dataset.max_instruction_length),
      config.waypoint_agent, config.panorama, config.sim.agent, numEnvs,
      sampleActions, seed);
}

void runWaypointAgentTraining(const ExperimentConfig& config,
                              const fs::path& runDir) {
  validateWaypointAgentConfig(config);
  common::Stopwatch clock;
  const TrainerConfig& tc = config.trainer;
  const rollout::EvalConfig& ec = config.eval;
  fs::create_directories(runDir / "checkpoints");

  TrainingData data = TrainingData::load(config);
  WaypointAgentModels nets = makeWaypointAgentModels(config, true);
  const std::shared_ptr<models::WaypointCmaPolicyImpl>& policy = nets.policy;
  // fine-tuning (with trainer.fine_tune_dagger: DAgger rounds on the
  // agent's own paths from the first) starts from another run's weights
  const std::string& init = tc.init_checkpoint;
  if (!init.empty()) {
    models::loadStateStrict(*policy, readPolicyWeights(init), init);
    spdlog::info("{}: initialised the policy from {}", kTask, init);
  }
  std::vector<torch::Tensor> parameters;
  for (const torch::Tensor& p : policy->parameters())
    if (p.requires_grad()) parameters.push_back(p);
  torch::optim::Adam optimizer(parameters, torch::optim::AdamOptions(tc.lr));
  int64_t parameterCount = 0;
  for (const torch::Tensor& p : parameters) parameterCount += p.numel();

  auto scenes = std::make_shared<rollout::SceneCache>(config.sim);
  rollout::VectorEnv envs(tc.num_envs, config.sim, config.task, scenes,
                          tc.env_threads);
  std::unique_ptr<PeriodicEvaluator> evaluator;
  if (tc.eval_during_training)
    evaluator = std::make_unique<PeriodicEvaluator>(config, scenes, nullptr);
  CheckpointKeeper keeper(config, runDir / "checkpoints", true);
  MetricsLog metrics(runDir / "metrics.jsonl",
                     config.output.tensorboard ? runDir / "tb" : fs::path());
  metrics.write("start",
                {{"resumed", false},
                 {"init_checkpoint", init},
                 {"checkpoint", -1},
                 {"updates", 0},
                 {"setup_seconds", clock.seconds()}},
                {}, 0);
  spdlog::info(
      "{}: {} trainable policy parameters, candidates from {}, {} "
      "training episodes in the pool",
      kTask, parameterCount, config.waypoint_agent.candidates,
      data.pool.size());

  // mirrored replays read the instruction with "left" and "right" swapped
  const double mirrorProbability = config.waypoint_agent.mirror_probability;
  const MirrorTokens mirrorTokens =
      mirrorProbability > 0.0 ? mirrorTokensOf(config, data) : MirrorTokens{};
  std::mt19937_64 mirrorRng(
      common::deriveSeed(static_cast<uint64_t>(tc.seed), 23));
  const double subInstructionWeight =
      config.waypoint_agent.sub_instruction_weight;
  // with leg_words_only each decision reads the words of the clauses ahead
  const bool legWordsOnly = config.waypoint_agent.leg_words_only;
  // with model.clause_tracker the pointer's targets, and the episodes that
  // read the oracle's clause in each batch
  const bool clauseTracker = config.model.clause_tracker;
  std::mt19937_64 clauseRng(
      common::deriveSeed(static_cast<uint64_t>(tc.seed), 29));
  const SubInstructionTokensByEpisode subInstructionTokens =
      subInstructionWeight > 0.0 || legWordsOnly || clauseTracker
          ? loadSubInstructionTokens(config, data)
          : SubInstructionTokensByEpisode{};

  const TrainingSchedule schedule(tc);
  TrainingProgress progress;
  progress.checkpoint_index = -1;
  progress.stage = schedule.dagger() ? "dagger" : "teacher_forcing";
  const int K = config.waypoint_agent.max_candidates;
  const torch::Device device = models::modelDevice(config.model);
  std::vector<CollectedEpisode> collected;
  std::mt19937_64 orderRng(
      common::deriveSeed(static_cast<uint64_t>(tc.seed), 17));
  bool stop = false;

  for (const ScheduledIteration& iteration : schedule.remaining(0, 0)) {
    if (stop) break;
    if (iteration.collect) {
      common::Stopwatch roundClock;
      std::vector<const data::Episode*> episodes;
      for (size_t i :
           schedule.roundEpisodes(iteration.iteration, data.pool.size()))
        episodes.push_back(data.pool[i]);
      const std::unique_ptr<rollout::WaypointAgent> agent =
          makeWaypointAgent(config, nets, tc.num_envs, false, 0);
      if (legWordsOnly)
        agent->readLegWordsOnly(subInstructionTokens,
                                config.dataset.max_instruction_length);
      rollout::WaypointCollection how;
      how.beta = schedule.beta(iteration.iteration);
      how.sample = tc.dagger_action == "sample";
      how.mirror = mirrorProbability > 0.0;
      how.seed =
          common::deriveSeed(static_cast<uint64_t>(tc.seed),
                             1000 + static_cast<uint64_t>(iteration.iteration));
      agent->collect(how);
      const size_t before = collected.size();
      DecisionCollection job(episodes, *agent, envs, collected);
      const rollout::RolloutCounts counts = rollout::runEpisodes(
          envs, static_cast<int>(episodes.size()), job, /*render=*/false);
      int64_t decisions = 0;
      for (size_t i = before; i < collected.size(); ++i)
        decisions += static_cast<int64_t>(collected[i].decisions.size());
      policy->train();
      const double success =
          counts.episodes > 0
              ? static_cast<double>(job.successes()) / counts.episodes
              : 0.0;
      spdlog::info(
          "{}: round {} (beta {:.3f}): {} episodes, {} decisions, {} steps in "
          "{:.1f} s, {:.3f} ended within the goal radius; {} episodes "
          "aggregated",
          kTask, iteration.iteration, how.beta, counts.episodes, decisions,
          counts.steps, roundClock.seconds(), success, collected.size());
      metrics.write("collect",
                    {{"iteration", iteration.iteration},
                     {"beta", how.beta},
                     {"episodes", counts.episodes},
                     {"decisions", decisions},
                     {"steps", counts.steps},
                     {"success", success},
                     {"seconds", roundClock.seconds()}},
                    {}, progress.updates);
    }

    for (const ScheduledEpoch& epoch : iteration.epochs) {
      common::Stopwatch epochClock;
      std::vector<size_t> order(collected.size());
      std::iota(order.begin(), order.end(), size_t{0});
      common::deterministicShuffle(order, orderRng);
      double lossSum = 0.0, contrastSum = 0.0, subInstructionSum = 0.0,
             progressSum = 0.0, clauseSum = 0.0;
      int64_t correct = 0, acceptedHits = 0, labelled = 0, batches = 0;
      // the tracker's advances that matched their targets
      int64_t clauseHits = 0, clauseCounted = 0;
      // the first decision of each episode, where the instruction's opening
      // ("turn left ...") is all that tells the candidates apart
      int64_t firstCorrect = 0, firstLabelled = 0;
      policy->train();
      const double lr = schedule.learningRate(iteration.iteration, epoch.epoch);
      setAdamLearningRate(optimizer, lr);
      for (size_t start = 0; start < order.size(); start += tc.batch_size) {
        const size_t end = std::min(order.size(), start + tc.batch_size);
        std::vector<const std::vector<rollout::WaypointDecision>*> rows;
        std::vector<const data::Episode*> instructions;
        // the batch's mirrored replays (mirroredDecision()), kept alive
        // until batchDecisions() has copied them
        std::vector<std::vector<rollout::WaypointDecision>> mirroredRows;
        std::vector<bool> mirrored;
        mirroredRows.reserve(end - start);
        for (size_t i = start; i < end; ++i) {
          const CollectedEpisode& e = collected[order[i]];
          const bool mirror = mirrorProbability > 0.0 &&
                              common::uniform01(mirrorRng) < mirrorProbability;
          mirrored.push_back(mirror);
          if (mirror) {
            auto& m = mirroredRows.emplace_back();
            for (const rollout::WaypointDecision& d : e.decisions)
              m.push_back(rollout::mirroredDecision(d));
            rows.push_back(&m);
          } else {
            rows.push_back(&e.decisions);
          }
          instructions.push_back(e.episode);
        }
        rollout::WaypointBatch batch = rollout::batchDecisions(rows, K);
        auto& in = batch.inputs;
        for (torch::Tensor* t : {&in.rgb, &in.depth, &in.candidates,
                                 &in.candidate_mask, &in.prev, &in.not_done})
          if (t->defined()) *t = t->to(device);
        const torch::Tensor labels = batch.labels.to(device).reshape({-1});
        torch::Tensor tokens = rollout::batchInstructions(
            instructions, config.dataset.max_instruction_length);
        if (mirrorProbability > 0.0 && config.model.usesInstruction())
          tokens = rollout::swapLeftAndRight(
              tokens, mirrored, mirrorTokens.left, mirrorTokens.right);
        if (legWordsOnly)
          in.text_mask =
              subInstructionTargets(rows, instructions, subInstructionTokens,
                                    tokens.size(1))
                  .gt(0.0f)
                  .to(device);
        if (clauseTracker) {
          std::vector<uint8_t> teacher;
          for (size_t b = 0; b < rows.size(); ++b)
            teacher.push_back(
                common::uniform01(clauseRng) <
                        config.waypoint_agent.clause_teacher_probability
                    ? 1
                    : 0);
          in.clause_of_token =
              rollout::batchRuleClauses(instructions, tokens.size(1))
                  .to(device);
          in.clause_targets =
              clauseTargets(rows, instructions, subInstructionTokens)
                  .to(device);
          in.clause_teacher =
              torch::tensor(teacher).to(torch::kBool).to(device);
        }
        if (config.model.goal_match)
          in.goal_labels = rollout::batchGoalLabels(instructions).to(device);
        const models::EncodedInstruction instruction =
            policy->encodeInstruction(tokens.to(device));
        const models::WaypointPolicyOutputs out = policy->forwardSequence(
            instruction, in,
            policy->initialHidden(static_cast<int64_t>(rows.size())));
        const torch::Tensor logits = out.logits.reshape({labels.size(0), -1});
        const torch::Tensor acceptable =
            batch.acceptable.to(device).reshape({labels.size(0), -1});
        torch::Tensor loss = acceptedSetLoss(logits, labels, acceptable);
        if (tc.instruction_contrast_weight > 0.0 && rows.size() > 1) {
          const torch::Tensor contrast = instructionContrastLoss(
              *policy, in, logits, labels, instructions,
              config.dataset.max_instruction_length, device);
          contrastSum += contrast.item<double>();
          loss = loss + tc.instruction_contrast_weight * contrast;
        }
        if (subInstructionWeight > 0.0) {
          const torch::Tensor targets =
              subInstructionTargets(rows, instructions, subInstructionTokens,
                                    out.text_attention.size(-1));
          const torch::Tensor sub =
              subInstructionLoss(out.text_attention, targets.to(device));
          subInstructionSum += sub.item<double>();
          loss = loss + subInstructionWeight * sub;
        }
        if (clauseTracker && out.clause_targets.ge(0).any().item<bool>()) {
          // the advance from the pointer before each decision that reaches
          // the oracle's clause (staying where it is past it, two at most)
          const torch::Tensor target =
              (out.clause_targets - out.clause_before)
                  .clamp(0, models::kClauseAdvances - 1)
                  .reshape({-1});
          const torch::Tensor counted =
              out.clause_targets.reshape({-1}).ge(0).logical_and(labels.ge(0));
          const torch::Tensor clauseLogits =
              out.clause_logits.reshape({-1, models::kClauseAdvances})
                  .index({counted});
          const torch::Tensor clauseLoss = torch::nn::functional::cross_entropy(
              clauseLogits, target.index({counted}));
          clauseSum += clauseLoss.item<double>();
          clauseHits += clauseLogits.argmax(1)
                            .eq(target.index({counted}))
                            .sum()
                            .item<int64_t>();
          clauseCounted += clauseLogits.size(0);
          loss =
              loss + config.waypoint_agent.clause_tracker_weight * clauseLoss;
        }
        if (out.progress.defined()) {
          const torch::Tensor progressLoss = models::progressLoss(
              out.progress,
              progressTargets(rows, instructions, tc.clip_progress_target)
                  .to(device),
              labels.ge(0).view_as(out.progress));
          progressSum += progressLoss.item<double>();
          loss = loss + tc.progress_loss_weight * progressLoss;
        }
        optimizer.zero_grad();
        loss.backward();
        optimizer.step();
        ++progress.updates;
        ++batches;
        lossSum += loss.item<double>();
        {
          torch::NoGradGuard noGrad;
          const torch::Tensor valid = labels.ge(0);
          const torch::Tensor choices = logits.argmax(1);
          const torch::Tensor hits = choices.eq(labels).logical_and(valid);
          correct += hits.sum().item<int64_t>();
          acceptedHits += acceptable.gather(1, choices.unsqueeze(1))
                              .squeeze(1)
                              .logical_and(valid)
                              .sum()
                              .item<int64_t>();
          labelled += valid.sum().item<int64_t>();
          // labels are [T, B] flattened: t = 0 is the first B entries
          const auto B = static_cast<int64_t>(rows.size());
          firstCorrect += hits.slice(0, 0, B).sum().item<int64_t>();
          firstLabelled += valid.slice(0, 0, B).sum().item<int64_t>();
        }
        if (progress.updates % tc.log_every_updates == 0)
          metrics.write("train",
                        {{"loss", loss.item<double>()},
                         {"iteration", iteration.iteration},
                         {"epoch", epoch.epoch}},
                        {{"train/loss", loss.item<double>()}},
                        progress.updates);
      }
      const double meanLoss = batches > 0 ? lossSum / batches : 0.0;
      const double meanContrast = batches > 0 ? contrastSum / batches : 0.0;
      const double meanSubInstruction =
          batches > 0 ? subInstructionSum / batches : 0.0;
      const double meanProgress = batches > 0 ? progressSum / batches : 0.0;
      const double meanClause = batches > 0 ? clauseSum / batches : 0.0;
      const double clauseAccuracy =
          clauseCounted > 0 ? static_cast<double>(clauseHits) / clauseCounted
                            : 0.0;
      const double accuracy =
          labelled > 0 ? static_cast<double>(correct) / labelled : 0.0;
      const double acceptedAccuracy =
          labelled > 0 ? static_cast<double>(acceptedHits) / labelled : 0.0;
      const double firstAccuracy =
          firstLabelled > 0 ? static_cast<double>(firstCorrect) / firstLabelled
                            : 0.0;
      spdlog::info(
          "{}: iteration {} epoch {}: {} updates, loss {:.4f} (instruction "
          "contrast {:.4f}, sub-instruction {:.4f}, progress {:.4f}, clause "
          "tracker {:.4f}), label accuracy {:.3f} over {} decisions ({:.3f} at "
          "the first decision, {:.3f} an accepted choice; the clause "
          "tracker's {:.3f}), {:.1f} s",
          kTask, iteration.iteration, epoch.epoch, batches, meanLoss,
          meanContrast, meanSubInstruction, meanProgress, meanClause, accuracy,
          labelled, firstAccuracy, acceptedAccuracy, clauseAccuracy,
          epochClock.seconds());
      metrics.write("epoch",
                    {{"iteration", iteration.iteration},
                     {"epoch", epoch.epoch},
                     {"loss", meanLoss},
                     {"instruction_contrast", meanContrast},
                     {"sub_instruction", meanSubInstruction},
                     {"progress", meanProgress},
                     {"clause_tracker", meanClause},
                     {"clause_accuracy", clauseAccuracy},
                     {"accuracy", accuracy},
                     {"first_decision_accuracy", firstAccuracy},
                     {"accepted_accuracy", acceptedAccuracy},
                     {"lr", lr},
                     {"updates", progress.updates},
                     {"seconds", epochClock.seconds()}},
                    {{"train/epoch_loss", meanLoss},
                     {"train/label_accuracy", accuracy},
                     {"train/first_decision_accuracy", firstAccuracy}},
                    progress.updates);

      ++progress.checkpoint_index;
      progress.dagger_iteration = epoch.iterations_done;
      progress.epoch = epoch.epochs_done;
      keeper.save(trainingCheckpoint(experimentConfigYaml(config), *policy,
                                     optimizer, progress));

      if (evaluator && epoch.evaluate_after) {
        const int index = progress.checkpoint_index;
        const double spl = evaluator->evaluateAgent(
            index, progress.updates,
            [&](const data::Split& split) -> std::unique_ptr<rollout::Agent> {
              std::unique_ptr<rollout::WaypointAgent> agent = makeWaypointAgent(
                  config, nets, ec.num_envs, ec.sample_actions,
                  static_cast<uint64_t>(ec.seed));
              readSplitLegWords(*agent, config, split);
              return agent;
            },
            &metrics);
        policy->train();
        if (keeper.recordEvaluation(progress, index, spl)) {
          spdlog::info("{}: early stopping after checkpoint {}", kTask, index);
          stop = true;
          break;
        }
      }
    }
  }
  spdlog::info("{}: done in {:.1f} s, {} updates; best checkpoint {}", kTask,
               clock.seconds(), progress.updates, progress.best_checkpoint);
}

}  // namespace vln::train
