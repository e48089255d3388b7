#include "train/Recollection.h"

#include <spdlog/spdlog.h>
#include <torch/torch.h>

#include <algorithm>

#include "common/Check.h"
#include "common/Progress.h"
#include "data/Vocabulary.h"
#include "rollout/EpisodeScheduler.h"
#include "rollout/ObservationBatch.h"
#include "train/Collector.h"

namespace vln::train {

// ---------------------------------------------------------------------------
// the pool

namespace {

// the split behind pool source `source` (TrainingData's numbering)
const data::Split& splitOfSource(const TrainingData& data, uint8_t source) {
  if (source == 0) return data.train;
  if (source == 1) {
    VLN_ASSERT(data.aug != nullptr);
    return *data.aug;
  }
  const size_t k = static_cast<size_t>(source) - 2;
  VLN_ASSERT(k < data.extra.size());
  return *data.extra[k];
}

// a ground truth the replay can follow to its end, or an error naming it
void checkReplayable(const data::GroundTruthPath& path,
                     const data::Episode& episode, const data::Split& split,
                     const ExperimentConfig& config) {
  const auto where = [&] {
    return strCat("recollect: split '", split.name,
                  "' ground truth of episode ", episode.episode_id);
  };
  const std::vector<sim::Action>& actions = path.actions;
  VLN_CHECK_ARG(!actions.empty(), where(), " has no actions");
  const int allowed =
      std::min(sim::numActions(config.sim.agent), config.model.num_actions);
  for (size_t t = 0; t < actions.size(); ++t) {
    const int code = static_cast<int>(actions[t]);
    VLN_CHECK_ARG(code < allowed, where(), ": actions[", t, "] is ", code,
                  ", outside the ", allowed,
                  " actions of sim.agent and model.num_actions");
    VLN_CHECK_ARG(actions[t] != sim::Action::kStop || t + 1 == actions.size(),
                  where(), ": actions[", t, "] is STOP before the last of its ",
                  actions.size(), " actions");
  }
  VLN_CHECK_ARG(actions.back() == sim::Action::kStop, where(),
                ": the last of its actions is ",
                static_cast<int>(actions.back()),
                ", not STOP (0); the replay would not end");
  VLN_CHECK_ARG(
      static_cast<int64_t>(actions.size()) <= config.task.max_episode_steps,
      where(), " has ", actions.size(),
      " actions, more than task.max_episode_steps = ",
      config.task.max_episode_steps,
      " (the environment would cut it); set trainer.max_traj_len to leave "
      "such episodes out, as VLN-CE's RxR configs do");
}

}  // namespace

RecollectionPool recollectionPool(const TrainingData& data,
                                  const ExperimentConfig& config) {
  RecollectionPool pool;
  const int maxLength = config.trainer.max_traj_len;
  for (size_t i = 0; i < data.pool.size(); ++i) {
    const data::Episode& episode = *data.pool[i];
    const data::Split& split = splitOfSource(data, data.sources[i]);
    const data::GroundTruthPath* path = nullptr;
    if (split.groundTruth) {
      auto it = split.groundTruth->find(episode.episode_id);
      if (it != split.groundTruth->end()) path = &it->second;
    }
    if (!path) {
      ++pool.without_ground_truth;
      continue;
    }
    // left out, not cut: VLN-CE skips the whole trajectory
    if (maxLength != -1 &&
        static_cast<int64_t>(path->actions.size()) > maxLength) {
      ++pool.over_max_traj_len;
      continue;
    }
    checkReplayable(*path, episode, split, config);
    pool.episodes.push_back({&episode, data.sources[i], path});
  }
  VLN_CHECK_ARG(!pool.episodes.empty(),
                "recollect: no training episode has a ground "
                "truth to replay (",
                pool.without_ground_truth,
                " without one in their split's _gt.json.gz, ",
                pool.over_max_traj_len,
                " longer than trainer.max_traj_len = ", maxLength, ")");
  return pool;
}

LocationAgreement compareLocations(std::span<const Vec3f> positions,
                                   std::span<const Vec3f> locations,
                                   double tolerance) {
  LocationAgreement agreement;
  if (positions.size() != locations.size()) return agreement;
  for (size_t i = 0; i < positions.size(); ++i)
    agreement.max_error =
        std::max(agreement.max_error,
                 static_cast<double>((positions[i] - locations[i]).norm()));
  agreement.same = agreement.max_error <= tolerance;
  return agreement;
}

// ---------------------------------------------------------------------------
// the replay

/// The replay of a list of episodes on the episode scheduler.
class Recollector::Job : public rollout::EpisodeJob {
 public:
  Job(Recollector& r, std::span<const RecollectEpisode> episodes,
      std::vector<RecollectedEpisode>& out)
      : r_(r),
        config_(r.config_),
        episodes_(episodes),
        out_(out),
        slots_(static_cast<size_t>(r.envs_->size())) {}

  rollout::EpisodeStart startOf(int index) override {
    return rollout::EpisodeStart::of(
        *episodes_[static_cast<size_t>(index)].episode);
  }

  void started(const rollout::EnvBatch& batch) override {
    for (size_t k = 0; k < batch.size(); ++k) {
      const int env = batch.envs[k];
      const RecollectEpisode& e =
          episodes_[static_cast<size_t>(batch.episodes[k])];
      Slot& s = slots_[static_cast<size_t>(env)];
      s = Slot{};
      s.index = batch.episodes[k];
      s.goal = e.episode->goals.front().position;
      const sim::NavMesh& navmesh = r_.envs_->simulator(env).scene().navmesh();
      s.startDistance =
          e.episode->geodesic_distance
              ? *e.episode->geodesic_distance
              : navmesh.geodesicDistance(e.episode->start_position, s.goal);
      s.positions.push_back(r_.envs_->state(env).agent.position);
    }
  }

  // the features of the current observations, then the ground truth's
  // action at each environment's step
  std::vector<sim::Action> act(const rollout::EnvBatch& running) override {
    const torch::Device device = models::modelDevice(config_.model);
    const rollout::ObservationBatch obs =
        rollout::batchObservations(*r_.envs_, running.envs, config_.model);
    auto on = [&](const torch::Tensor& t) {
      return t.defined() ? t.to(device) : t;
    };
    const models::VisualFeatures features =
        r_.encoder_->forward(on(obs.rgb), on(obs.depth));
    auto cpu = [](const torch::Tensor& t) {
      return t.defined() ? t.to(torch::kCPU, torch::kFloat32) : t;
    };
    const torch::Tensor rgb = cpu(features.rgb), depth = cpu(features.depth);

    std::vector<float> targets(running.size());
    r_.envs_->forEach(running.envs, [&](int env) {
      const Slot& s = slots_[static_cast<size_t>(env)];
      targets[running.indexOf(env)] = progressTarget(
          s.startDistance,
          r_.envs_->simulator(env).scene().navmesh().geodesicDistance(
              r_.envs_->state(env).agent.position, s.goal),
          config_.trainer.clip_progress_target);
    });

    std::vector<sim::Action> actions(running.size());
    for (size_t k = 0; k < running.size(); ++k) {
      Slot& s = slots_[static_cast<size_t>(running.envs[k])];
      const auto& truth =
          episodes_[static_cast<size_t>(s.index)].ground_truth->actions;
      const size_t t = s.labels.size();
      // the pool ends every sequence with its only STOP, so an environment
      // still running has a next action
      VLN_ASSERT(t < truth.size());
      if (rgb.defined()) s.rgb.push_back(rgb[static_cast<int64_t>(k)].clone());
      if (depth.defined())
        s.depth.push_back(depth[static_cast<int64_t>(k)].clone());
      s.prevActions.push_back(t == 0 ? uint8_t{0}
                                     : static_cast<uint8_t>(truth[t - 1]));
      s.labels.push_back(static_cast<uint8_t>(truth[t]));
      s.progress.push_back(targets[k]);
      actions[k] = truth[t];
    }
    return actions;
  }

  // where each step left the agent (a location when it moved)
  void stepped(const rollout::EnvBatch& running,
               std::span<const sim::Action> actions,
               std::span<const sim::StepResult> results) override {
    (void)actions;
    (void)results;
    for (int env : running.envs) {
      Slot& s = slots_[static_cast<size_t>(env)];
      const Vec3f& now = r_.envs_->state(env).agent.position;
      if (now != s.positions.back()) s.positions.push_back(now);
    }
  }

  void finished(const rollout::EnvBatch& ended) override {
    for (int env : ended.envs) {
      Slot& s = slots_[static_cast<size_t>(env)];
      const RecollectEpisode& e = episodes_[static_cast<size_t>(s.index)];
      // VLN-CE asserts this too: the replay is the whole ground truth
      if (s.labels.size() != e.ground_truth->actions.size())
        throw std::runtime_error(
            strCat("Recollector: episode ", e.episode->episode_id,
                   " ended after ", s.labels.size(), " of its ",
                   e.ground_truth->actions.size(), " ground-truth actions"));
      RecollectedEpisode& done = out_[static_cast<size_t>(s.index)];
      StoredEpisode& stored = done.stored;
      stored.key.episode_id = e.episode->episode_id;
      stored.key.slot = s.index;
      stored.key.source = e.source;
      stored.key.length = static_cast<int32_t>(s.labels.size());
      const auto& tokens = e.episode->instruction.instruction_tokens;
      const int length = std::min(data::unpaddedLength(tokens),
                                  config_.dataset.max_instruction_length);
      stored.tokens.assign(tokens.begin(), tokens.begin() + length);
      stored.prev_actions = std::move(s.prevActions);
      stored.oracle_actions = std::move(s.labels);
      stored.progress = std::move(s.progress);
      if (!s.rgb.empty()) stored.rgb = torch::stack(s.rgb);
      if (!s.depth.empty()) stored.depth = torch::stack(s.depth);
      done.positions = std::move(s.positions);
      s = Slot{};
    }
  }

 private:
  // one environment's episode in progress
  struct Slot {
    int index = -1;  ///< into the replayed list
    Vec3f goal = Vec3f::Zero();
    float startDistance = 0.0f;
    std::vector<torch::Tensor> rgb, depth;  ///< per step [C, h, w]
    std::vector<uint8_t> prevActions, labels;
    std::vector<float> progress;
    std::vector<Vec3f> positions;
  };

  Recollector& r_;
  const ExperimentConfig& config_;
  std::span<const RecollectEpisode> episodes_;
  std::vector<RecollectedEpisode>& out_;
  std::vector<Slot> slots_;  // per environment
};

Recollector::Recollector(const ExperimentConfig& config,
                         std::shared_ptr<rollout::SceneCache> scenes,
                         models::ObservationEncoder encoder)
    : config_(config),
      scenes_(std::move(scenes)),
      encoder_(std::move(encoder)) {
  envs_ = std::make_unique<rollout::VectorEnv>(
      config_.trainer.num_envs, config_.sim, config_.task, scenes_,
      config_.trainer.env_threads);
}

Recollector::~Recollector() = default;

std::vector<RecollectedEpisode> Recollector::replay(
    std::span<const RecollectEpisode> episodes, ReplayStats* stats) {
  std::vector<RecollectedEpisode> out(episodes.size());
  if (episodes.empty()) return out;
  const common::Stopwatch clock;
  torch::NoGradGuard noGrad;
  encoder_->eval();
  // VLN-CE's BatchNorm in train mode while collecting (Collector.cpp), off
  // again afterwards: evaluation shares this encoder
  struct BatchStatistics {
    models::ObservationEncoder& encoder;
    BatchStatistics(models::ObservationEncoder& e, bool on) : encoder(e) {
      encoder->useRgbBatchStatistics(on);
    }
    ~BatchStatistics() { encoder->useRgbBatchStatistics(false); }
  } batchStatistics(encoder_, config_.model.rgb_batch_statistics);

  Job job(*this, episodes, out);
  const rollout::RolloutCounts counts = rollout::runEpisodes(
      *envs_, static_cast<int>(episodes.size()), job, /*render=*/true);
  if (stats) {
    stats->episodes += counts.episodes;
    stats->steps += counts.steps;
    for (size_t i = 0; i < episodes.size(); ++i) {
      const LocationAgreement a = compareLocations(
          out[i].positions, episodes[i].ground_truth->locations,
          /*tolerance=*/0.01);
      stats->off_ground_truth += !a.same;
      stats->max_location_error =
          std::max(stats->max_location_error, a.max_error);
    }
    stats->seconds += clock.seconds();
  }
  return out;
}

}  // namespace vln::train
