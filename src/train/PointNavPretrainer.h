#pragma once
// Depth encoder pretraining by point-goal navigation (trainer.task =
// depth_pointnav), the stand-in for DD-PPO's point-goal agent whose ResNet
// VLN-CE freezes (paper Section 4).
//
// The task is DD-PPO's: the agent sees depth only plus the goal in polar
// coordinates relative to itself at every step (pointgoal_with_gps_compass),
// and succeeds by calling STOP within pretrain.success_distance (geodesic)
// of the goal. Episodes start at a uniformly random point of a house's main
// navmesh island with a random heading; the goal is another point of that
// island at a geodesic distance in [pretrain.min_goal_distance,
// pretrain.max_goal_distance].
//
// The policy (models::PointNavPolicy) is small and recurrent: depth CNN
// (model.depth_encoder, trained here) -> linear + ReLU projection
// (model.depth_projection_size), a linear goal embedding (32, as DD-PPO),
// a previous-action embedding (32, as DD-PPO), a GRU (pretrain.hidden_size)
// and an action head. It imitates the geodesic follower
// (sim::ShortestPathFollower with goal radius pretrain.success_distance,
// so the follower STOPs inside the success radius) with DAgger as the VLN
// trainer does it: iteration n (of pretrain.iterations) runs
// pretrain.samples new training episodes taking the follower's action with
// probability beta = trainer.dagger_beta^n and the policy's argmax
// otherwise, always recording the follower's action as the label, then
// trains pretrain.epochs_per_iteration epochs over everything aggregated
// so far with the inflection-weighted cross-entropy (models/Loss.h,
// coefficient trainer.inflection_weight; <= 0: the inverse inflection
// frequency of iteration 0's labels). Depth frames are kept as uint16
// (1/65535 of the depth range), bounded by pretrain.max_memory_gib.
//
// Reference: a blind control (the same network without the depth input)
// is trained on the very same batches, so the gap between the two measures
// what the depth encoder contributes. Held-out results (pretrain.
// eval_samples episodes in the held-out houses) are reported for the
// policy, the blind control, a random agent (uniform among MOVE_FORWARD,
// TURN_LEFT and TURN_RIGHT, STOP once the goal sensor reads within the
// success radius: habitat's RandomAgent) and the follower (upper bound).
//
// Reads: pretrain.*, trainer.seed, trainer.torch_threads, trainer.num_envs
// (episodes stepped together), trainer.env_threads (rendering threads),
// trainer.dagger_beta, trainer.inflection_weight, trainer.grad_clip,
// trainer.max_nonfinite_updates, trainer.log_every_updates, task.
// max_episode_steps, sim.* (depth camera, agent, navmesh, renderer),
// model.depth_* and output.tensorboard.

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <utility>
#include <vector>

#include "models/PointNavPolicy.h"
#include "sim/Agent.h"
#include "sim/Scene.h"
#include "train/PointGoalRollouts.h"
#include "train/ExperimentConfig.h"

namespace vln::train {

/// Held-out point-goal results of one agent (means over episodes).
struct PointNavMetrics {
  int64_t episodes = 0;
  double success = 0.0;           ///< STOP within success_distance (geodesic)
  double spl = 0.0;               ///< success * d0 / max(d0, path length)
  double distance_to_goal = 0.0;  ///< final geodesic distance, metres
  double path_length = 0.0;       ///< metres walked
  double steps = 0.0;             ///< actions taken
};

/// What a run produced.
struct PointNavResult {
  PointNavMetrics policy;  ///< depth policy, greedy
  PointNavMetrics blind;   ///< no-depth control, greedy
  PointNavMetrics random;  ///< habitat's RandomAgent
  PointNavMetrics oracle;  ///< the follower
  double initial_loss = 0.0;     ///< action loss of the untrained policy
                                 ///< on its first batch
  double final_loss = 0.0;       ///< mean action loss of the last epoch
  double blind_final_loss = 0.0; ///< the same for the blind control
  double inflection_coef = 0.0;
  int64_t frames = 0;            ///< aggregated training frames
  double memory_gib = 0.0;       ///< bytes of the aggregated frames
  double seconds = 0.0;          ///< wall clock of the whole run
  std::filesystem::path encoder_file;
};

/// Runs the whole task in `runDir` (metrics.jsonl, tb/,
/// pretrain_metrics.json, the encoder file, pointnav_policy.pt with the
/// whole policy).
class PointNavPretrainer {
 public:
  /// Checks the config (validatePretrainConfig()) and generates the houses.
  PointNavPretrainer(const ExperimentConfig& config,
                     std::filesystem::path runDir);
  ~PointNavPretrainer();
  PointNavResult run();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vln::train
