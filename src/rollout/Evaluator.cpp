#include "rollout/Evaluator.h"

#include <string>

#include "common/Check.h"
#include "rollout/EpisodeScheduler.h"

namespace vln::rollout {
namespace {

// The reference path of a scored episode: ground-truth locations when a
// ground truth is given (VLN-CE's nDTW reads them from *_gt.json.gz), else
// the episode's reference_path.
std::vector<Vec3f> referencePath(const data::Episode& episode,
                                 const data::GroundTruth* groundTruth) {
  if (groundTruth == nullptr) return episode.reference_path;
  auto it = groundTruth->find(episode.episode_id);
  VLN_CHECK_ARG(it != groundTruth->end(), "evaluateEpisodes(): episode ",
                episode.episode_id, " (scene ", episode.scene_id,
                ") has no entry in the ground truth");
  return it->second.locations;
}

}  // namespace

MetricsOptions metricsOptions(const EvalConfig& config,
                              double successDistance) {
  MetricsOptions options;
  options.success_distance = successDistance;
  VLN_CHECK_ARG(config.dtw == "exact" || config.dtw == "fast",
                "metricsOptions(): eval.dtw must be exact or fast, got '",
                config.dtw, "'");
  options.dtw = config.dtw == "fast" ? DtwMethod::kFast : DtwMethod::kExact;
  return options;
}

namespace {

// The record of an episode that ended in `simulator`, with its metrics when
// the episode has a goal.
EpisodeResult finishRecord(EpisodeRecord record, const data::Episode& episode,
                           const std::vector<Vec3f>& reference,
                           const sim::Simulator& simulator,
                           const EvalConfig& config) {
  const sim::EpisodeState& state = simulator.episode();
  record.called_stop = state.called_stop;
  record.steps_taken = state.steps;
  EpisodeResult out;
  if (!episode.goals.empty()) {
    const sim::NavMesh& navmesh = simulator.scene().navmesh();
    record.goal = episode.goals.front().position;
    record.reference_path = reference;
    record.start_distance =
        navmesh.geodesicDistance(record.positions.front(), record.goal);
    const GeodesicFn geodesic = [&navmesh](const Vec3f& a, const Vec3f& b) {
      return navmesh.geodesicDistance(a, b);
    };
    out.metrics = computeEpisodeMetrics(
        record, geodesic,
        metricsOptions(config, simulator.task().success_distance));
  }
  out.record = std::move(record);
  return out;
}

// Runs an Agent on a list of episodes and records them (the evaluation
// job of the episode scheduler).
class EvaluationJob : public EpisodeJob {
 public:
  EvaluationJob(Agent& agent, VectorEnv& envs,
                const std::vector<data::Episode>& episodes,
                std::vector<std::vector<Vec3f>> references,
                const EvalConfig& config,
                const std::function<void(int, int)>& progress,
                EpisodeObserver* observer, EvaluationResult& result)
      : agent_(agent),
        envs_(envs),
        episodes_(episodes),
        references_(std::move(references)),
        config_(config),
        progress_(progress),
        observer_(observer),
        result_(result),
        records_(static_cast<size_t>(envs.size())) {}

  EpisodeStart startOf(int index) override {
    return EpisodeStart::of(episodes_[static_cast<size_t>(index)]);
  }

  void started(const EnvBatch& batch) override {
    renderForObserver(batch);
    for (size_t k = 0; k < batch.size(); ++k) {
      const int env = batch.envs[k];
      const data::Episode& episode =
          episodes_[static_cast<size_t>(batch.episodes[k])];
      const sim::AgentState& pose = envs_.state(env).agent;
      EpisodeRecord& record = records_[static_cast<size_t>(env)];
      record = EpisodeRecord{};
      record.episode_id = std::to_string(episode.episode_id);
      record.positions = {pose.position};
      record.headings = {pose.heading};
      if (recordPitches(env)) record.pitches = {pose.pitch};
      agent_.reset(env, episode);
      if (observer_) observer_->episodeStarted(batch.episodes[k], envs_, env);
    }
  }

  std::vector<sim::Action> act(const EnvBatch& running) override {
    std::vector<sim::Action> actions = agent_.act(envs_, running.envs);
    VLN_CHECK_ARG(actions.size() == running.size(),
                  "evaluateEpisodes(): the "
                  "agent returned ",
                  actions.size(), " actions for ", running.size(),
                  " environments");
    return actions;
  }

  void stepped(const EnvBatch& running, std::span<const sim::Action> actions,
               std::span<const sim::StepResult>) override {
    renderForObserver(running);
    for (size_t k = 0; k < running.size(); ++k) {
      const int env = running.envs[k];
      const sim::AgentState& pose = envs_.state(env).agent;
      EpisodeRecord& record = records_[static_cast<size_t>(env)];
      record.actions.push_back(static_cast<int>(actions[k]));
      record.positions.push_back(pose.position);
      record.headings.push_back(pose.heading);
      if (recordPitches(env)) record.pitches.push_back(pose.pitch);
      if (observer_)
        observer_->episodeStepped(running.episodes[k], envs_, env, actions[k]);
    }
  }

  // metrics in parallel (each writes only its own result), then the
  // callbacks in environment order
  void finished(const EnvBatch& ended) override {
    for (int env : ended.envs)
      records_[static_cast<size_t>(env)].waypoint_choices =
          agent_.waypointChoices(env);
    envs_.forEach(ended.envs, [&](int env) {
      const auto index =
          static_cast<size_t>(ended.episodes[ended.indexOf(env)]);
      result_.episodes[index] = finishRecord(
          std::move(records_[static_cast<size_t>(env)]), episodes_[index],
          references_[index], envs_.simulator(env), config_);
      result_.scored[index] = !episodes_[index].goals.empty();
    });
    for (size_t k = 0; k < ended.size(); ++k) {
      const auto index = static_cast<size_t>(ended.episodes[k]);
      if (observer_)
        observer_->episodeFinished(ended.episodes[k], envs_, ended.envs[k],
                                   result_.episodes[index],
                                   result_.scored[index]);
      ++finishedCount_;
      if (progress_)
        progress_(finishedCount_, static_cast<int>(episodes_.size()));
    }
  }

 private:
  // pitches are part of the record in RxR's action space only, so R2R
  // records and their files stay as they were
  bool recordPitches(int env) {
    return envs_.simulator(env).config().agent.look_actions;
  }

  // observations the observer wants although the agent does not read them
  void renderForObserver(const EnvBatch& batch) {
    if (agent_.needsObservations() || observer_ == nullptr) return;
    std::vector<int> wanted;
    for (size_t k = 0; k < batch.size(); ++k)
      if (observer_->wantsFrames(batch.episodes[k]))
        wanted.push_back(batch.envs[k]);
    if (!wanted.empty()) envs_.render(wanted);
  }

  Agent& agent_;
  VectorEnv& envs_;
  const std::vector<data::Episode>& episodes_;
  std::vector<std::vector<Vec3f>> references_;
  const EvalConfig& config_;
  const std::function<void(int, int)>& progress_;
  EpisodeObserver* observer_;
  EvaluationResult& result_;
  std::vector<EpisodeRecord> records_;  // per environment, while running
  int finishedCount_ = 0;
};

}  // namespace

// ---------------------------------------------------------------------------
// several observers

void EpisodeObservers::add(EpisodeObserver* observer) {
  if (observer != nullptr) observers_.push_back(observer);
}

EpisodeObserver* EpisodeObservers::single() {
  if (observers_.empty()) return nullptr;
  return observers_.size() == 1 ? observers_.front() : this;
}

bool EpisodeObservers::wantsFrames(int index) const {
  for (const EpisodeObserver* observer : observers_)
    if (observer->wantsFrames(index)) return true;
  return false;
}

void EpisodeObservers::episodeStarted(int index, VectorEnv& envs, int env) {
  for (EpisodeObserver* observer : observers_)
    observer->episodeStarted(index, envs, env);
}

void EpisodeObservers::episodeStepped(int index, VectorEnv& envs, int env,
                                      sim::Action action) {
  for (EpisodeObserver* observer : observers_)
    observer->episodeStepped(index, envs, env, action);
}

void EpisodeObservers::episodeFinished(int index, VectorEnv& envs, int env,
                                       const EpisodeResult& result,
                                       bool scored) {
  for (EpisodeObserver* observer : observers_)
    observer->episodeFinished(index, envs, env, result, scored);
}

// ---------------------------------------------------------------------------
// evaluation

EvaluationResult evaluateEpisodes(Agent& agent, VectorEnv& envs,
                                  const std::vector<data::Episode>& episodes,
                                  const data::GroundTruth* groundTruth,
                                  const EvalConfig& config,
                                  const std::function<void(int, int)>& progress,
                                  EpisodeObserver* observer) {
  EvaluationResult result;
  result.episodes.resize(episodes.size());
  result.scored.assign(episodes.size(), false);
  if (episodes.empty()) return result;

  // reference paths up front, so a missing ground-truth entry fails before
  // any episode runs rather than after an hour of evaluation
  std::vector<std::vector<Vec3f>> references(episodes.size());
  for (size_t i = 0; i < episodes.size(); ++i) {
    if (episodes[i].goals.empty()) continue;
    references[i] = referencePath(episodes[i], groundTruth);
    VLN_CHECK_ARG(!references[i].empty(), "evaluateEpisodes(): episode ",
                  episodes[i].episode_id, " has an empty reference path",
                  groundTruth ? " in the ground truth" : "");
  }

  EvaluationJob job(agent, envs, episodes, std::move(references), config,
                    progress, observer, result);
  runEpisodes(envs, static_cast<int>(episodes.size()), job,
              /*render=*/agent.needsObservations());

  result.stats = scoredStats(result);
  return result;
}

SplitStats scoredStats(const EvaluationResult& result) {
  VLN_ASSERT(result.scored.size() == result.episodes.size());
  std::vector<EpisodeMetrics> scored;
  for (size_t i = 0; i < result.episodes.size(); ++i)
    if (result.scored[i]) scored.push_back(result.episodes[i].metrics);
  return scored.empty() ? SplitStats{} : aggregate(scored);
}

}  // namespace vln::rollout
