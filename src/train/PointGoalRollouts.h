#pragma once
// The point-goal episodes of the depth encoder's pretraining
// (PointNavPretrainer.h): DD-PPO's goal sensor, sampling start/goal pairs
// on a house's navmesh, and running them on the episode scheduler
// (rollout/EpisodeScheduler.h), driven by the geodesic follower, the
// policy, a DAgger mixture of both, or habitat's random agent, optionally
// recording every step for training.

#include <torch/torch.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "models/PointNavPolicy.h"
#include "sim/Agent.h"
#include "sim/Scene.h"
#include "train/ExperimentConfig.h"

namespace vln::train {

/// uint16 depth code of the top of the sensor range.
inline constexpr float kDepthCodeMax = 65535.0f;

/// DD-PPO's pointgoal_with_gps_compass as its policy embeds it:
/// [rho, cos(phi), sin(phi)] with rho the horizontal Euclidean distance from
/// the agent to the goal (metres) and phi the direction of the goal relative
/// to the agent's heading (radians; 0 straight ahead, positive to the left,
/// i.e. counter-clockwise seen from above, as headings are).
std::array<float, 3> pointGoalObservation(const sim::AgentState& agent,
                                          const Vec3f& goal);

/// One point-goal episode.
struct PointGoalEpisode {
  int house = -1;              ///< index into the scene list it was drawn from
  sim::AgentState start;       ///< on the navmesh, world frame
  Vec3f goal = Vec3f::Zero();  ///< on the navmesh, world frame
  float geodesic_distance = 0.0f;  ///< start to goal, metres
};

/// `count` episodes over `scenes`: house uniform, start uniform on the
/// house's main island (island 0) with a uniform heading, goal uniform on
/// the same island at a geodesic distance in [minDistance, maxDistance].
/// Deterministic by `seed`. Throws std::invalid_argument naming the scene
/// when 1000 draws find no such goal (the range does not fit the house).
std::vector<PointGoalEpisode> samplePointGoalEpisodes(
    const std::vector<std::shared_ptr<const sim::Scene>>& scenes, int count,
    float minDistance, float maxDistance, uint64_t seed);

/// One recorded training episode; depth quantised to uint16 codes of the
/// sensor range, the rest as the policy reads it.
struct RecordedEpisode {
  std::vector<uint16_t> depth;  // [T, H * W]
  std::vector<float> goal;      // [T, 3]
  std::vector<int8_t> prev;     // [T], the action before step t (0 at t = 0)
  std::vector<int8_t> label;    // [T], the follower's action

  int64_t length() const { return static_cast<int64_t>(label.size()); }
  size_t bytes() const {
    return depth.size() * sizeof(uint16_t) + goal.size() * sizeof(float) +
           prev.size() + label.size();
  }

  /// Appends one step: the depth frame as uint16 codes of [0, depthScale].
  void append(std::span<const float> frame, float depthScale,
              const std::array<float, 3>& goalObservation, int prevAction,
              sim::Action followerAction) {
    const size_t offset = depth.size();
    depth.resize(offset + frame.size());
    for (size_t p = 0; p < frame.size(); ++p) {
      const float v = std::clamp(frame[p] / depthScale, 0.0f, 1.0f);
      depth[offset + p] = static_cast<uint16_t>(std::lround(v * kDepthCodeMax));
    }
    goal.insert(goal.end(), goalObservation.begin(), goalObservation.end());
    prev.push_back(static_cast<int8_t>(prevAction));
    label.push_back(static_cast<int8_t>(followerAction));
  }
};

/// Who picks the actions of a rollout.
enum class Driver {
  kMixed,   // DAgger: the follower with probability beta, else the policy
  kPolicy,  // the policy's argmax
  kRandom,  // habitat's RandomAgent
  kOracle,  // the follower
};

/// How an episode ended.
struct Outcome {
  bool success = false;
  double spl = 0.0;
  double distance = 0.0;
  double path = 0.0;
  int steps = 0;
};

/// One rollout of point-goal episodes: who drives and what is recorded.
struct RolloutSpec {
  Driver driver = Driver::kOracle;
  models::PointNavPolicyImpl* policy =
      nullptr;        // needed for kMixed and kPolicy
  double beta = 0.0;  // kMixed: the follower's probability
  uint64_t seed = 0;  // coins and random actions
  // with `record`, every step goes to (*record)[k] for episode k; the
  // recorded bytes plus `bytesBefore` must stay within `byteBudget`
  std::vector<RecordedEpisode>* record = nullptr;
  size_t bytesBefore = 0;
  size_t byteBudget = 0;
};

/// Runs `episodes` in `scenes` with trainer.num_envs environments on
/// trainer.env_threads threads as `spec` says (a progress line named
/// `label`); returns their outcomes in order. Throws std::runtime_error
/// naming pretrain.max_memory_gib when the recorded steps exceed the
/// budget.
std::vector<Outcome> runPointGoalEpisodes(
    const ExperimentConfig& config,
    const std::vector<std::shared_ptr<const sim::Scene>>& scenes,
    const std::vector<PointGoalEpisode>& episodes, const RolloutSpec& spec,
    torch::Device device, const std::string& label);

}  // namespace vln::train
