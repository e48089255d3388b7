#pragma once
// The episodes of the recollect trainer (RecollectTrainer.h) and their
// re-simulation: teacher forcing on the dataset's ground-truth action
// sequences (<split>_gt.json.gz, data/GroundTruth.h), replayed in the
// simulator every epoch instead of stored (VLN-CE's
// TeacherRecollectionDataset).
//
// An episode's replay starts at its start pose and takes the ground
// truth's actions in order; step t records the frozen encoders' features
// of the observation, the action before it (STOP = 0 at t = 0, then the
// ground truth's action t - 1), the label (the ground truth's action t, as
// VLN-CE: the oracle is the recording) and the progress target of
// Collector.h. The replay is the ground truth's actions whatever the
// simulator does; where it ends up is returned beside the features, so
// that callers can see whether the scenes reproduce the ground truth's
// locations (they do when they are the scenes it was recorded in).

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "common/Math.h"
#include "data/Episode.h"
#include "data/GroundTruth.h"
#include "models/ObservationEncoder.h"
#include "rollout/VectorEnv.h"
#include "train/ExperimentConfig.h"
#include "train/FeatureStore.h"
#include "train/TrainingData.h"

namespace vln::train {

/// One episode the recollect trainer replays.
struct RecollectEpisode {
  const data::Episode* episode = nullptr;
  uint8_t source = 0;  ///< pool source: 0 train, 1 aug, 2 + k extra split k
  const data::GroundTruthPath* ground_truth = nullptr;
  /// Actions of the ground truth (the episode's length in steps).
  int32_t length() const {
    return static_cast<int32_t>(ground_truth->actions.size());
  }
};

/// The episodes the recollect trainer learns from, and what it left out.
struct RecollectionPool {
  /// In pool order (TrainingData::pool: train, aug, extra splits).
  std::vector<RecollectEpisode> episodes;
  int64_t without_ground_truth = 0;  ///< pool episodes absent from their _gt
  /// Episodes with more than trainer.max_traj_len actions: left out (not
  /// cut), as VLN-CE's TeacherRecollectionDataset does.
  int64_t over_max_traj_len = 0;
};

/// The pool episodes of `data` whose split's ground truth holds them,
/// minus those longer than trainer.max_traj_len. Throws
/// std::invalid_argument naming the split, the episode and the file's
/// field for a kept ground truth that cannot be replayed: no actions, an
/// action outside the simulator's (sim.agent) or the policy's
/// (model.num_actions) action space, a STOP before the last action or a
/// last action that is not STOP, more actions than task.max_episode_steps
/// (the environment would cut it; VLN-CE asserts; trainer.max_traj_len
/// leaves such episodes out); and when no episode is left.
RecollectionPool recollectionPool(const TrainingData& data,
                                  const ExperimentConfig& config);

/// One replayed episode.
struct RecollectedEpisode {
  /// Features (float32), tokens, previous actions, labels and progress
  /// targets, as a feature store would hold them; key.slot is the
  /// episode's position in the replay() call.
  StoredEpisode stored;
  /// The start position, then the position after every action that moved
  /// the agent (the ground truth's `locations` convention), world frame,
  /// metres.
  std::vector<Vec3f> positions;
};

/// What a replay() call did.
struct ReplayStats {
  int64_t episodes = 0;
  int64_t steps = 0;
  double seconds = 0.0;
  /// Episodes whose positions differ from their ground truth's locations
  /// (another count, or a position more than 1 cm away).
  int64_t off_ground_truth = 0;
  /// The largest distance between a position and its location over the
  /// episodes with as many of both, metres.
  double max_location_error = 0.0;
};

/// Whether `positions` follow `locations` (as many, each within
/// `tolerance` metres), and the largest distance when they are as many.
struct LocationAgreement {
  bool same = false;
  double max_error = 0.0;
};
LocationAgreement compareLocations(std::span<const Vec3f> positions,
                                   std::span<const Vec3f> locations,
                                   double tolerance);

/// Replays ground-truth episodes on trainer.num_envs environments
/// (trainer.env_threads) through rollout::runEpisodes().
class Recollector {
 public:
  /// `encoder` runs frozen under NoGradGuard on model.device (with
  /// model.rgb_batch_statistics as in collection).
  Recollector(const ExperimentConfig& config,
              std::shared_ptr<rollout::SceneCache> scenes,
              models::ObservationEncoder encoder);
  ~Recollector();

  /// Replays `episodes` and returns them in the same order; `stats` (may
  /// be null) receives the counts. The features of an episode depend on
  /// the episodes sharing its environment batch by float rounding only
  /// (and through the batch's statistics with model.rgb_batch_statistics);
  /// for given `episodes` and trainer.num_envs they are always the same.
  /// Throws std::runtime_error naming the episode when an environment ends
  /// it before the ground truth's last action.
  std::vector<RecollectedEpisode> replay(
      std::span<const RecollectEpisode> episodes, ReplayStats* stats);

 private:
  class Job;
  ExperimentConfig config_;
  std::shared_ptr<rollout::SceneCache> scenes_;
  models::ObservationEncoder encoder_;
  std::unique_ptr<rollout::VectorEnv> envs_;
};

}  // namespace vln::train
