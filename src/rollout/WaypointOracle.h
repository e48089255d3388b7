#pragma once
// The oracle: VLN-CE's shortest-path expert over an episode's waypoints,
// used by the trainer to label and drive collection (train/Collector.h,
// trainer.expert) and, as OracleAgent, by the evaluator (`eval --agent
// oracle`), e.g. to dump expert trajectories for other models.
//
// With OracleMode::kGoal (VLN-CE's ShortestPathSensor) the follower heads
// for the episode's goal and STOPs within the goal radius
// (task.follower_goal_radius, 0.5 m by default). With kReferencePath it
// produces actions the way the R2R_VLNCE ground truth was produced
// (data/NodeTransfer.h): the follower heads for reference-path waypoint i
// until it would STOP there, then for waypoint i + 1, and STOPs at the last
// one. Positions are world frame (Y up), metres.

#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "common/Math.h"
#include "data/Episode.h"
#include "rollout/Agent.h"
#include "sim/Follower.h"

namespace vln::rollout {

/// What the oracle heads for.
enum class OracleMode {
  kGoal,           ///< the episode's (first) goal
  kReferencePath,  ///< the reference path's waypoints in order
};

/// The mode called `name`: "goal" or "reference_path" (trainer.expert's
/// values). Throws std::invalid_argument naming `option` and `name`
/// otherwise.
OracleMode parseOracleMode(std::string_view name, std::string_view option);

/// "goal" or "reference_path".
std::string_view oracleModeName(OracleMode mode);

/// The shortest-path follower over waypoints in order: an episode's
/// reference path or its goal alone.
class WaypointOracle {
 public:
  /// `waypoints` world frame, metres (at least one; throws
  /// std::invalid_argument otherwise). Waypoint 0 of several is the start:
  /// the first leg heads for waypoint 1. `navmesh` must outlive the oracle.
  WaypointOracle(const sim::NavMesh& navmesh, const sim::AgentConfig& agent,
                 float goalRadius, std::vector<Vec3f> waypoints);
  /// The oracle action at `state`; advances to the next waypoint whenever
  /// the follower would STOP at the current one (not the last).
  sim::Action next(const sim::AgentState& state);
  /// Index of the waypoint currently headed for.
  int waypoint() const { return current_; }

 private:
  sim::ShortestPathFollower follower_;
  std::vector<Vec3f> waypoints_;
  int current_ = 1;
};

/// The waypoints WaypointOracle follows in `episode` under `mode`: {its
/// first goal} or its reference path. Throws std::invalid_argument naming
/// the episode when it has none (an episode without goals, as in a test
/// split without ground truth, or an empty reference path).
std::vector<Vec3f> oracleWaypoints(const data::Episode& episode,
                                   OracleMode mode);

/// The oracle as an evaluation Agent: one WaypointOracle per environment,
/// built for the episode at reset() on the scene's navmesh. Deterministic
/// (an episode's actions depend on nothing but the episode and the scene)
/// and reads no observations.
class OracleAgent : public Agent {
 public:
  /// `agent` is the action space (sim.agent), `goalRadius` the follower's
  /// stopping radius in metres (task.follower_goal_radius); `numEnvs` >= 1
  /// bounds the environment indices.
  OracleAgent(const sim::AgentConfig& agent, float goalRadius, OracleMode mode,
              int numEnvs);
  /// Starts `episode` in environment `env`. Throws std::invalid_argument
  /// naming the episode when it has no goal (kGoal) or no reference path
  /// (kReferencePath).
  void reset(int env, const data::Episode& episode) override;
  /// The oracle action of every environment in `active` at its pose.
  std::vector<sim::Action> act(VectorEnv& envs,
                               std::span<const int> active) override;
  bool needsObservations() const override { return false; }
  OracleMode mode() const { return mode_; }

 private:
  struct Slot {
    std::vector<Vec3f> waypoints;  ///< of the episode started by reset()
    /// Built at the first act(), when the environment's navmesh is known.
    std::optional<WaypointOracle> oracle;
    bool started = false;
  };
  Slot& slotOf(int env, const char* method);

  sim::AgentConfig agent_;
  float goalRadius_;
  OracleMode mode_;
  std::vector<Slot> slots_;  ///< per environment
};

}  // namespace vln::rollout
