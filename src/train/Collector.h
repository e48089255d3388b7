#pragma once
// Collection of imitation-learning episodes into the feature store (paper
// Section 4.3): environments of an rollout::VectorEnv each run one episode at
// a time, driven either by the oracle or by a mixture of oracle and policy,
// and every step's encoded observation, previous action, oracle action
// (the label, always) and progress target is recorded.
//
// The oracle (rollout::WaypointOracle, trainer.expert) is VLN-CE's by
// default: the shortest-path follower with radius task.follower_goal_radius
// heading for the episode's goal (VLN-CE's ShortestPathSensor). With expert
// reference_path it produces actions the way the R2R_VLNCE ground truth was
// produced (data/NodeTransfer.h): the follower heads for reference-path
// waypoint i until it would STOP there, then for waypoint i + 1, and STOPs
// at the last one; teacher forcing (collection with beta = 1, the oracle's
// own trajectory) then reproduces the split's _gt actions (the agreement is
// measured and logged for either expert).
//
// DAgger (beta < 1): at each step the action taken is the oracle's with
// probability beta, else the policy's: sampled from its softmax
// (trainer.dagger_action sample, VLN-CE) or its argmax (the policy runs at
// every step so that its recurrent state follows the trajectory). The coin
// and the sample of slot k of round n are drawn from its own generator
// seeded by (seed, n, k), so
// which episodes are collected, and their coins, do not depend on the
// number of environments or on where a run was interrupted. The features
// and the policy's actions do, by float rounding, unless
// trainer.exact_resume runs every environment through the encoder and the
// policy on its own (batched arithmetic rounds differently for other batch
// shapes).
//
// A round is a fixed list of episodes ("slots"). Slots already in the store
// (from an interrupted run) are skipped, so resuming collects exactly the
// missing ones: nothing is lost or duplicated. Episodes end with STOP or at
// task.max_episode_steps (cut there; the last label is the oracle's action
// at that step).

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "data/Episode.h"
#include "data/GroundTruth.h"
#include "models/ObservationEncoder.h"
#include "models/Policy.h"
#include "rollout/ObservationBatch.h"
#include "rollout/VectorEnv.h"
#include "rollout/WaypointOracle.h"
#include "train/ExperimentConfig.h"
#include "train/FeatureStore.h"
#include "train/MetricsLog.h"

namespace vln::train {

class Distributed;

/// The oracle of trainer.expert (rollout/WaypointOracle.h), in the rollout
/// layer so that the evaluator can run it as an agent too.
using rollout::WaypointOracle;

/// The waypoints WaypointOracle follows in `episode` under trainer.expert
/// `expert`: {goal} or the reference path (rollout::oracleWaypoints()).
/// Throws std::invalid_argument naming trainer.expert for another value.
std::vector<Vec3f> expertWaypoints(const data::Episode& episode,
                                   const std::string& expert);

/// Progress target of VLN-CE's oracle progress sensor, (d0 - d) / d0 with d
/// the geodesic distance to the goal and d0 the episode's
/// info.geodesic_distance; 0 when d is not finite (VLN-CE's rule). VLN-CE
/// leaves it unclipped (below -1 more than 2 d0 from the goal); `clip`
/// clips it to [-1, 1], the range of the tanh progress head.
float progressTarget(float startDistance, float distance, bool clip);

/// The index drawn from the softmax of `logits` by a uniform number `u` in
/// [0, 1): the first index whose cumulative probability exceeds u (inverse
/// CDF sampling, as torch.multinomial over one draw).
int64_t sampleFromLogits(std::span<const float> logits, double u);

/// The episodes of one collection round: slot k runs episodes[k].
struct CollectionRound {
  std::vector<const data::Episode*> episodes;
  std::vector<uint8_t> sources;  ///< per slot: 0 train split, 1 aug split
  int32_t iteration = 0;         ///< DAgger iteration (0: teacher forcing)
  double beta = 1.0;             ///< probability of taking the oracle action
  uint64_t seed = 0;             ///< seed of the run (coins derive from it)
  /// A multi-process run partitions the round by rank: this call collects
  /// only the slots k with k % num_shards == shard. Slot numbers, coins and
  /// store keys stay those of the whole round, so the shards together hold
  /// what one process would collect.
  int32_t shard = 0;
  int32_t num_shards = 1;
};

/// What a round collected.
struct CollectionStats {
  /// These counts summed over the processes of a multi-process run by
  /// `sum` (an all-reduce), the wall time the slowest one's by `max`.
  CollectionStats overRanks(
      const std::function<std::vector<double>(const std::vector<double>&)>&
          sum,
      const std::function<int64_t(int64_t)>& max) const;

  int64_t episodes = 0;      ///< episodes appended by this call
  int64_t skipped = 0;       ///< slots already in the store
  int64_t steps = 0;         ///< steps appended
  int64_t oracle_steps = 0;  ///< steps that took the oracle action
  int64_t cut_at_limit = 0;  ///< episodes cut at task.max_episode_steps
  double seconds = 0.0;
  /// Teacher forcing only: episodes compared with the split's ground truth
  /// and those whose action sequence is identical; steps compared position
  /// by position and those equal.
  int64_t gt_episodes = 0;
  int64_t gt_identical = 0;
  int64_t gt_steps = 0;
  int64_t gt_equal_steps = 0;
};

class Collector {
 public:
  /// `encoder` is used frozen under NoGradGuard on model.device. The
  /// environments are built here (trainer.num_envs, trainer.env_threads).
  Collector(const ExperimentConfig& config,
            std::shared_ptr<rollout::SceneCache> scenes,
            models::ObservationEncoder encoder);
  ~Collector();

  /// Where a policy with model.instruction_features: rxr_text gets each
  /// episode's text features when it runs (DAgger rounds, beta < 1;
  /// TrainingData::textFeatureSource()). Teacher forcing needs none.
  void setInstructionFeatures(rollout::InstructionFeatureSource source) {
    featureSource_ = std::move(source);
  }

  /// Runs the missing slots of `round` (of its shard) and appends each
  /// finished episode
  /// to `store` (one transaction each). `policy` is needed when
  /// round.beta < 1 (eval mode, no grad). `groundTruth` (of the source-0
  /// split), when given and beta == 1, is compared with the oracle's
  /// actions of the source-0 slots. `progress` is called
  /// after every stored episode with (stored so far in this round, slots in
  /// the round).
  CollectionStats collect(
      const CollectionRound& round, FeatureStore& store,
      const std::shared_ptr<models::PolicyImpl>& policy,
      const data::GroundTruth* groundTruth,
      const std::function<void(int64_t, int64_t)>& progress = {});

 private:
  struct Slot;
  class Job;
  // the encoder's features of `obs` on model.device: one batch, or one row
  // at a time with trainer.exact_resume
  models::VisualFeatures encode(const rollout::ObservationBatch& obs);
  ExperimentConfig config_;
  std::shared_ptr<rollout::SceneCache> scenes_;
  models::ObservationEncoder encoder_;
  std::unique_ptr<rollout::VectorEnv> envs_;
  rollout::InstructionFeatureSource featureSource_;
};

/// Hash (16 hex digits) of everything that determines what the feature
/// store holds: sim, task, dataset (splits and caps), the encoders
/// (architecture, weight files, image sizes, ablations), the seed and the
/// collection settings (use_aug, dagger_episodes, dagger_beta,
/// fine_tune_dagger, store_fp16).
std::string storeConfigHash(const ExperimentConfig& config);

/// The feature store of `config` in `dir` (created, or reopened when its
/// layout and storeConfigHash() match; FeatureStore.h), logged.
std::unique_ptr<FeatureStore> openFeatureStore(const ExperimentConfig& config,
                                               const std::filesystem::path& dir);

/// Episodes and bytes per step of the stores of all processes together.
struct StoreTotals {
  int64_t episodes = 0;
  double bytes_per_step = 0.0;
};
/// `store`'s totals, summed over the ranks of `dist` (a collective) when
/// it is not null.
StoreTotals totalsOverRanks(const FeatureStore& store, Distributed* dist);

/// Logs what collection round `round` collected and writes its "collect"
/// record to `metrics` (may be null); the oracle's agreement with the
/// ground truth of split `trainSplit` is a warning when not perfect and
/// `expertFollowsGroundTruth` (trainer.expert reference_path).
void logCollection(const CollectionStats& stats, const CollectionRound& round,
                   const StoreTotals& totals, const std::string& trainSplit,
                   bool expertFollowsGroundTruth, MetricsLog* metrics);

}  // namespace vln::train
