#pragma once
// The no-learning baselines of paper Table 1 (top rows), as action sources
// that ignore observations (VLN-CE vlnce_baselines/nonlearning_agents.py):
//  - Random: samples every action from the training set's ground-truth
//    action distribution (VLN-CE: STOP 0.02, MOVE_FORWARD 0.68, TURN_LEFT
//    0.15, TURN_RIGHT 0.15).
//  - Hand-crafted: turns right a uniformly random number of times in
//    0..24 (a random heading in 15 degree steps; 0..12 with RxR-Habitat's
//    30 degree turns), walks forward for the
//    mean training path length in steps (37 in the paper: 9.27 m / 0.25 m),
//    then calls STOP.
// Both are deterministic: reset(episodeId) seeds the episode's draws from
// the agent seed and the episode id, so results do not depend on the order
// or the thread in which episodes run.

#include <array>
#include <cstdint>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "sim/Agent.h"

namespace vln::eval {

/// Probability of each action, indexed by sim::Action code (0 STOP,
/// 1 MOVE_FORWARD, 2 TURN_LEFT, 3 TURN_RIGHT).
using ActionDistribution = std::array<double, sim::kNumActions>;

/// VLN-CE's RandomAgent default, the train-split distribution the paper
/// quotes in Sec. 5.1.
inline constexpr ActionDistribution kPaperActionDistribution = {0.02, 0.68,
                                                                0.15, 0.15};
/// Forward steps of the paper's hand-crafted agent (nonlearning_agents.py:
/// 9.27 m mean oracle path length in train / 0.25 m per step).
inline constexpr int kPaperHandcraftedForwardSteps = 37;
/// Largest number of initial TURN_RIGHT actions: VLN-CE draws
/// np.random.randint(0, int(360 / 15) + 1), whose upper bound is exclusive.
inline constexpr int kHandcraftedMaxTurns = 24;

/// The same rule for turns of `turnAngleDeg` degrees: int(360 / angle)
/// (24 for R2R's 15 degrees, 12 for RxR-Habitat's 30), so that the random
/// heading covers the circle whatever the task's turn. Throws
/// std::invalid_argument unless 0 < turnAngleDeg <= 360.
int handcraftedMaxTurns(double turnAngleDeg);

/// Frequencies of the action codes over all ground-truth action sequences
/// (e.g. the "actions" lists of train_gt.json.gz). Throws
/// std::invalid_argument naming the sequence and position of a code outside
/// 0..3, or when there are no actions at all.
ActionDistribution actionDistribution(
    std::span<const std::vector<int>> sequences);

/// Hand-crafted forward steps from data: the mean of `pathLengths` (metres,
/// e.g. ground-truth path lengths of the train split) divided by the forward
/// step size (metres), rounded to the nearest integer. Throws
/// std::invalid_argument for empty input or a non-positive step size.
int handcraftedForwardSteps(std::span<const double> pathLengths,
                            double forwardStepSize);

/// An action source that needs no observations.
class BaselineAgent {
 public:
  virtual ~BaselineAgent() = default;
  /// Starts episode `episodeId`; re-seeds the agent's random draws.
  virtual void reset(std::string_view episodeId) = 0;
  /// The next action of the current episode (call reset() first).
  virtual sim::Action act() = 0;
  /// Short name ("random", "handcrafted").
  virtual std::string name() const = 0;
};

/// Samples each action independently from a fixed distribution.
class RandomAgent : public BaselineAgent {
 public:
  /// `probabilities` must be non-negative with a positive sum (they are
  /// normalised); throws std::invalid_argument otherwise.
  explicit RandomAgent(
      ActionDistribution probabilities = kPaperActionDistribution,
      uint64_t seed = 0);
  void reset(std::string_view episodeId) override;
  sim::Action act() override;
  std::string name() const override { return "random"; }
  /// The normalised distribution in use.
  const ActionDistribution& probabilities() const { return probabilities_; }

 private:
  ActionDistribution probabilities_{};
  uint64_t seed_;
  std::mt19937_64 rng_;
};

/// TURN_RIGHT x k (k uniform in 0..maxTurns), MOVE_FORWARD x forwardSteps,
/// then STOP (repeated if asked again).
class HandcraftedAgent : public BaselineAgent {
 public:
  /// Throws std::invalid_argument for negative counts.
  explicit HandcraftedAgent(int forwardSteps = kPaperHandcraftedForwardSteps,
                            int maxTurns = kHandcraftedMaxTurns,
                            uint64_t seed = 0);
  void reset(std::string_view episodeId) override;
  sim::Action act() override;
  std::string name() const override { return "handcrafted"; }
  /// TURN_RIGHT actions drawn for the current episode.
  int turns() const { return turns_; }

 private:
  bool started_ = false;  // act() before the first reset() is a bug
  int forwardSteps_;
  int maxTurns_;
  uint64_t seed_;
  int turns_ = 0;
  int turnsLeft_ = 0;
  int forwardLeft_ = 0;
};

/// "random" -> RandomAgent(distribution, seed), "handcrafted" ->
/// HandcraftedAgent(forwardSteps, maxTurns, seed); throws
/// std::invalid_argument naming any other `name`.
std::unique_ptr<BaselineAgent> makeBaseline(
    std::string_view name, const ActionDistribution& distribution,
    int forwardSteps, int maxTurns, uint64_t seed);

}  // namespace vln::eval
