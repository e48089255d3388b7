#include "rollout/EpisodeScheduler.h"

#include <algorithm>

#include "common/Check.h"

namespace vln::rollout {

size_t EnvBatch::indexOf(int env) const {
  const auto it = std::lower_bound(envs.begin(), envs.end(), env);
  VLN_ASSERT(it != envs.end() && *it == env);
  return static_cast<size_t>(it - envs.begin());
}

RolloutCounts runEpisodes(VectorEnv& envs, int count, EpisodeJob& job,
                          bool render) {
  RolloutCounts counts;
  // episodeOf[env]: the episode environment env runs, -1 while idle
  std::vector<int> episodeOf(static_cast<size_t>(envs.size()), -1);
  int next = 0;

  // gives the next pending episodes to `idle` (increasing), lowest first
  auto start = [&](const std::vector<int>& idle) {
    EnvBatch started;
    std::vector<EpisodeStart> starts;
    for (int env : idle) {
      if (next >= count) break;
      starts.push_back(job.startOf(next));
      episodeOf[static_cast<size_t>(env)] = next;
      started.envs.push_back(env);
      started.episodes.push_back(next++);
    }
    if (started.empty()) return;
    envs.reset(started.envs, starts, render);
    job.started(started);
  };

  std::vector<int> all(static_cast<size_t>(envs.size()));
  for (int env = 0; env < envs.size(); ++env)
    all[static_cast<size_t>(env)] = env;
  start(all);

  while (true) {
    EnvBatch running;
    for (int env = 0; env < envs.size(); ++env) {
      const int episode = episodeOf[static_cast<size_t>(env)];
      if (episode < 0) continue;
      running.envs.push_back(env);
      running.episodes.push_back(episode);
    }
    if (running.empty()) break;

    const std::vector<sim::Action> actions = job.act(running);
    VLN_CHECK_ARG(actions.size() == running.size(),
                  "runEpisodes(): the job "
                  "chose ",
                  actions.size(), " actions for ", running.size(),
                  " environments");
    const std::vector<sim::StepResult> results =
        envs.step(running.envs, actions, render);
    counts.steps += static_cast<int64_t>(running.size());
    job.stepped(running, actions, results);

    // the simulator ends an episode at STOP or at task.max_episode_steps
    EnvBatch ended;
    for (size_t k = 0; k < running.size(); ++k) {
      if (!envs.state(running.envs[k]).done) continue;
      ended.envs.push_back(running.envs[k]);
      ended.episodes.push_back(running.episodes[k]);
    }
    if (ended.empty()) continue;
    job.finished(ended);
    counts.episodes += static_cast<int64_t>(ended.size());
    for (int env : ended.envs) episodeOf[static_cast<size_t>(env)] = -1;
    start(ended.envs);
  }
  return counts;
}

}  // namespace vln::rollout
