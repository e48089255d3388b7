#include "eval/Baselines.h"

#include <cmath>
#include <numeric>

#include "common/Check.h"
#include "common/Random.h"

namespace vln::eval {

// ---------------------------------------------------------------------------
// statistics from data
// ---------------------------------------------------------------------------

ActionDistribution actionDistribution(
    std::span<const std::vector<int>> sequences) {
  std::array<int64_t, sim::kNumActions> counts{};
  int64_t total = 0;
  for (size_t s = 0; s < sequences.size(); ++s) {
    for (size_t t = 0; t < sequences[s].size(); ++t) {
      const int code = sequences[s][t];
      VLN_CHECK_ARG(code >= 0 && code < sim::kNumActions,
                    "actionDistribution(): sequence ", s, " action ", t,
                    " is not an action code 0..3, got ", code);
      ++counts[code];
      ++total;
    }
  }
  VLN_CHECK_ARG(total > 0, "actionDistribution(): no actions in ",
                sequences.size(), " sequences");
  ActionDistribution out{};
  for (int a = 0; a < sim::kNumActions; ++a)
    out[a] = static_cast<double>(counts[a]) / static_cast<double>(total);
  return out;
}

int handcraftedForwardSteps(std::span<const double> pathLengths,
                            double forwardStepSize) {
  VLN_CHECK_ARG(!pathLengths.empty(),
                "handcraftedForwardSteps(): no path lengths given");
  VLN_CHECK_ARG(forwardStepSize > 0.0,
                "handcraftedForwardSteps(): forward step size must be "
                "positive, got ",
                forwardStepSize);
  double sum = 0.0;
  for (size_t i = 0; i < pathLengths.size(); ++i) {
    VLN_CHECK_ARG(std::isfinite(pathLengths[i]) && pathLengths[i] >= 0.0,
                  "handcraftedForwardSteps(): path length ", i,
                  " must be finite and >= 0, got ", pathLengths[i]);
    sum += pathLengths[i];
  }
  const double mean = sum / static_cast<double>(pathLengths.size());
  return static_cast<int>(std::lround(mean / forwardStepSize));
}

int handcraftedMaxTurns(double turnAngleDeg) {
  VLN_CHECK_ARG(turnAngleDeg > 0.0 && turnAngleDeg <= 360.0,
                "handcraftedMaxTurns(): turn angle must be in (0, 360] "
                "degrees, got ",
                turnAngleDeg);
  // 360 / 30 must give 12, not 11.999...: a hair of slack before flooring
  return static_cast<int>(std::floor(360.0 / turnAngleDeg + 1e-9));
}

// ---------------------------------------------------------------------------
// random agent
// ---------------------------------------------------------------------------

RandomAgent::RandomAgent(ActionDistribution probabilities, uint64_t seed)
    : seed_(seed), rng_(seed) {
  double sum = 0.0;
  for (int a = 0; a < sim::kNumActions; ++a) {
    VLN_CHECK_ARG(std::isfinite(probabilities[a]) && probabilities[a] >= 0.0,
                  "RandomAgent::RandomAgent(): probability of action ", a,
                  " must be finite and >= 0, got ", probabilities[a]);
    sum += probabilities[a];
  }
  VLN_CHECK_ARG(sum > 0.0,
                "RandomAgent::RandomAgent(): probabilities sum to zero");
  for (int a = 0; a < sim::kNumActions; ++a)
    probabilities_[a] = probabilities[a] / sum;
}

void RandomAgent::reset(std::string_view episodeId) {
  rng_.seed(common::episodeSeed(seed_, episodeId));
}

sim::Action RandomAgent::act() {
  // inverse-CDF sampling; the last action with non-zero mass absorbs
  // rounding so a draw near 1 never falls off the end
  const double u = common::uniform01(rng_);
  double cumulative = 0.0;
  int chosen = sim::kNumActions - 1;
  while (chosen > 0 && probabilities_[chosen] == 0.0) --chosen;
  for (int a = 0; a < sim::kNumActions; ++a) {
    cumulative += probabilities_[a];
    if (probabilities_[a] > 0.0 && u < cumulative) {
      chosen = a;
      break;
    }
  }
  return static_cast<sim::Action>(chosen);
}

// ---------------------------------------------------------------------------
// hand-crafted agent
// ---------------------------------------------------------------------------

HandcraftedAgent::HandcraftedAgent(int forwardSteps, int maxTurns,
                                   uint64_t seed)
    : forwardSteps_(forwardSteps), maxTurns_(maxTurns), seed_(seed) {
  VLN_CHECK_ARG(forwardSteps >= 0,
                "HandcraftedAgent::HandcraftedAgent(): forward steps must be "
                ">= 0, got ",
                forwardSteps);
  VLN_CHECK_ARG(maxTurns >= 0,
                "HandcraftedAgent::HandcraftedAgent(): max turns must be "
                ">= 0, got ",
                maxTurns);
}

void HandcraftedAgent::reset(std::string_view episodeId) {
  std::mt19937_64 rng(common::episodeSeed(seed_, episodeId));
  // uniform in 0..maxTurns_ (inclusive) by scaling a [0, 1) draw
  turns_ = static_cast<int>(common::uniform01(rng) * (maxTurns_ + 1));
  turnsLeft_ = turns_;
  forwardLeft_ = forwardSteps_;
  started_ = true;
}

sim::Action HandcraftedAgent::act() {
  VLN_ASSERT(started_);
  if (turnsLeft_ > 0) {
    --turnsLeft_;
    return sim::Action::kTurnRight;
  }
  if (forwardLeft_ > 0) {
    --forwardLeft_;
    return sim::Action::kMoveForward;
  }
  return sim::Action::kStop;
}

std::unique_ptr<BaselineAgent> makeBaseline(
    std::string_view name, const ActionDistribution& distribution,
    int forwardSteps, int maxTurns, uint64_t seed) {
  if (name == "random")
    return std::make_unique<RandomAgent>(distribution, seed);
  if (name == "handcrafted")
    return std::make_unique<HandcraftedAgent>(forwardSteps, maxTurns, seed);
  throw std::invalid_argument(
      strCat("makeBaseline(): unknown baseline '", name,
             "', expected one of: random, handcrafted"));
}

}  // namespace vln::eval
