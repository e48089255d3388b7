#pragma once
// Runs an Agent over a split's episodes in a VectorEnv and computes VLN-CE's
// metrics (Metrics.h) from the recorded paths.

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "data/Episode.h"
#include "data/GroundTruth.h"
#include "rollout/Agent.h"
#include "rollout/EvalConfig.h"
#include "rollout/Metrics.h"
#include "rollout/VectorEnv.h"

namespace vln::rollout {

/// Everything one evaluation produced.
struct EvaluationResult {
  std::vector<EpisodeResult> episodes;  ///< in the order of the input episodes
  SplitStats stats;                     ///< means over `episodes` with goals
  /// Whether episodes[i] has metrics (false for episodes without goals,
  /// e.g. the test split). Bytes, not std::vector<bool>: environment
  /// threads set neighbouring entries at once, and vector<bool> packs them
  /// into shared words (that race dropped episodes from the means).
  std::vector<uint8_t> scored;
};

/// Means over the episodes of `result` marked scored, in their order (what
/// evaluateEpisodes() puts in result.stats); num_episodes 0 when none.
SplitStats scoredStats(const EvaluationResult& result);

/// Watches episodes while they run, e.g. to draw maps or write videos
/// (EpisodePictures.h). All calls come from the thread that called
/// evaluateEpisodes(), one episode at a time; `index` is the episode's
/// position in the input list.
class EpisodeObserver {
 public:
  virtual ~EpisodeObserver() = default;
  /// True when episode `index` needs a rendered observation after reset and
  /// after every step even if the agent does not read observations.
  virtual bool wantsFrames(int index) const = 0;
  /// Environment `env` of `envs` has just started episode `index`; its
  /// observation is current when the agent reads observations or
  /// wantsFrames(index).
  virtual void episodeStarted(int index, VectorEnv& envs, int env) = 0;
  /// Environment `env` has taken `action` in episode `index` (observation
  /// current under the same rule as episodeStarted()).
  virtual void episodeStepped(int index, VectorEnv& envs, int env,
                              sim::Action action) = 0;
  /// Episode `index` ended (STOP or step limit); `result` holds its record
  /// and, when `scored`, its metrics. The environment still holds the
  /// episode's scene and final state.
  virtual void episodeFinished(int index, VectorEnv& envs, int env,
                               const EpisodeResult& result, bool scored) = 0;
};

/// Several observers watching one evaluation (pictures, a report, dumps):
/// each call goes to every observer in the order added; frames are wanted
/// when any observer wants them. Null observers are skipped.
class EpisodeObservers : public EpisodeObserver {
 public:
  /// Adds `observer` (not owned; must outlive this; null is ignored).
  void add(EpisodeObserver* observer);
  /// Observers added.
  size_t size() const { return observers_.size(); }
  bool empty() const { return observers_.empty(); }
  /// What to hand to evaluateEpisodes(): null without observers, the only
  /// one itself, else this fan-out.
  EpisodeObserver* single();

  bool wantsFrames(int index) const override;
  void episodeStarted(int index, VectorEnv& envs, int env) override;
  void episodeStepped(int index, VectorEnv& envs, int env,
                      sim::Action action) override;
  void episodeFinished(int index, VectorEnv& envs, int env,
                       const EpisodeResult& result, bool scored) override;

 private:
  std::vector<EpisodeObserver*> observers_;
};

/// Runs `agent` on every episode of `episodes` (the caller caps the list;
/// batched over envs.size() environments, an environment is refilled with
/// the next episode as soon as its episode ends; argmax or sampling is the
/// agent's business) until STOP or task.max_episode_steps, recording
/// positions, headings and actions, then computes the metrics with the
/// scene's navmesh geodesic and task.success_distance. Reference paths come
/// from `groundTruth` locations when given (an episode missing from it is an
/// error naming the episode), else the episode's reference_path. Episodes
/// without goals (test split) are run and recorded but get no metrics
/// (stats over the others; zero episodes give stats with num_episodes 0).
/// The result does not depend on config.threads. Observations are rendered
/// only when agent.needsObservations() (or the observer wants frames).
/// `progress`, when set, is called after each finished episode with (done,
/// total).
EvaluationResult evaluateEpisodes(
    Agent& agent, VectorEnv& envs, const std::vector<data::Episode>& episodes,
    const data::GroundTruth* groundTruth, const EvalConfig& config,
    const std::function<void(int, int)>& progress = {},
    EpisodeObserver* observer = nullptr);

/// MetricsOptions of `config` (dtw) with `successDistance` metres.
MetricsOptions metricsOptions(const EvalConfig& config, double successDistance);

}  // namespace vln::rollout
