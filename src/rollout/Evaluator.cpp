#include "rollout/Evaluator.h"

#include <string>

#include "common/Check.h"

namespace vln::rollout {
namespace {

// One environment's running episode: which input episode it is and what
// has been recorded so far.
struct Slot {
  int index = -1;  // position in the input list; -1 while idle
  EpisodeRecord record;
};

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

EvaluationResult evaluateEpisodes(Agent& agent, VectorEnv& envs,
                                  const std::vector<data::Episode>& episodes,
                                  const data::GroundTruth* groundTruth,
                                  const EvalConfig& config,
                                  const std::function<void(int, int)>& progress,
                                  EpisodeObserver* observer) {
  const int total = static_cast<int>(episodes.size());
  EvaluationResult result;
  result.episodes.resize(episodes.size());
  result.scored.assign(episodes.size(), false);
  if (total == 0) return result;

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

  const bool agentReads = agent.needsObservations();
  const int numEnvs = envs.size();
  std::vector<Slot> slots(static_cast<size_t>(numEnvs));
  int next = 0;
  int finishedCount = 0;

  // observations the observer wants although the agent does not read them
  auto renderForObserver = [&](const std::vector<int>& list) {
    if (agentReads || observer == nullptr) return;
    std::vector<int> wanted;
    for (int env : list)
      if (observer->wantsFrames(slots[static_cast<size_t>(env)].index))
        wanted.push_back(env);
    if (!wanted.empty()) envs.render(wanted);
  };

  // gives the next episodes to the listed idle environments, lowest
  // environment first, so the schedule depends on nothing but numEnvs
  auto start = [&](const std::vector<int>& idle) {
    std::vector<int> started;
    std::vector<const data::Episode*> starting;
    for (int env : idle) {
      if (next >= total) break;
      slots[static_cast<size_t>(env)].index = next;
      started.push_back(env);
      starting.push_back(&episodes[static_cast<size_t>(next)]);
      ++next;
    }
    if (started.empty()) return;
    envs.reset(started, starting, /*render=*/agentReads);
    renderForObserver(started);
    for (int env : started) {
      Slot& slot = slots[static_cast<size_t>(env)];
      const data::Episode& episode = episodes[static_cast<size_t>(slot.index)];
      const sim::AgentState& pose = envs.state(env).agent;
      slot.record = EpisodeRecord{};
      slot.record.episode_id = std::to_string(episode.episode_id);
      slot.record.positions = {pose.position};
      slot.record.headings = {pose.heading};
      agent.reset(env, episode);
      if (observer) observer->episodeStarted(slot.index, envs, env);
    }
  };

  // finishes the episodes of the listed environments: metrics in parallel
  // (each writes only its own result), then callbacks in environment order
  auto finish = [&](const std::vector<int>& ended) {
    envs.forEach(ended, [&](int env) {
      Slot& slot = slots[static_cast<size_t>(env)];
      const auto index = static_cast<size_t>(slot.index);
      const data::Episode& episode = episodes[index];
      const sim::Simulator& simulator = envs.simulator(env);
      const sim::EpisodeState& state = simulator.episode();
      EpisodeRecord& record = slot.record;
      record.called_stop = state.called_stop;
      record.steps_taken = state.steps;
      EpisodeResult& out = result.episodes[index];
      if (!episode.goals.empty()) {
        const sim::NavMesh& navmesh = simulator.scene().navmesh();
        record.goal = episode.goals.front().position;
        record.reference_path = references[index];
        record.start_distance =
            navmesh.geodesicDistance(record.positions.front(), record.goal);
        const GeodesicFn geodesic = [&navmesh](const Vec3f& a, const Vec3f& b) {
          return navmesh.geodesicDistance(a, b);
        };
        out.metrics = computeEpisodeMetrics(
            record, geodesic,
            metricsOptions(config, simulator.task().success_distance));
        result.scored[index] = true;
      }
      out.record = std::move(record);
    });
    for (int env : ended) {
      Slot& slot = slots[static_cast<size_t>(env)];
      const auto index = static_cast<size_t>(slot.index);
      if (observer)
        observer->episodeFinished(slot.index, envs, env, result.episodes[index],
                                  result.scored[index]);
      slot.index = -1;
      ++finishedCount;
      if (progress) progress(finishedCount, total);
    }
  };

  std::vector<int> all(static_cast<size_t>(numEnvs));
  for (int env = 0; env < numEnvs; ++env) all[static_cast<size_t>(env)] = env;
  start(all);

  while (true) {
    std::vector<int> active;
    for (int env = 0; env < numEnvs; ++env)
      if (slots[static_cast<size_t>(env)].index >= 0) active.push_back(env);
    if (active.empty()) break;

    // one action per active environment, then one step of each
    const std::vector<sim::Action> actions = agent.act(envs, active);
    VLN_CHECK_ARG(actions.size() == active.size(),
                  "evaluateEpisodes(): the "
                  "agent returned ",
                  actions.size(), " actions for ", active.size(),
                  " environments");
    envs.step(active, actions, /*render=*/agentReads);
    renderForObserver(active);

    // record the new poses; the simulator ends an episode at STOP or at
    // task.max_episode_steps
    std::vector<int> ended;
    for (size_t k = 0; k < active.size(); ++k) {
      const int env = active[k];
      Slot& slot = slots[static_cast<size_t>(env)];
      const sim::EpisodeState& state = envs.state(env);
      slot.record.actions.push_back(static_cast<int>(actions[k]));
      slot.record.positions.push_back(state.agent.position);
      slot.record.headings.push_back(state.agent.heading);
      if (observer) observer->episodeStepped(slot.index, envs, env, actions[k]);
      if (state.done) ended.push_back(env);
    }
    if (ended.empty()) continue;
    finish(ended);
    start(ended);
  }

  // means over the scored episodes, in input order
  std::vector<EpisodeMetrics> scored;
  for (size_t i = 0; i < episodes.size(); ++i)
    if (result.scored[i]) scored.push_back(result.episodes[i].metrics);
  if (!scored.empty()) result.stats = aggregate(scored);
  return result;
}

}  // namespace vln::rollout
