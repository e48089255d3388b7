#include "train/TrainingSchedule.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "common/Random.h"

namespace vln::train {
namespace {

// stream label of the round shuffles (common::deriveSeed)
constexpr uint64_t kRoundStream = 7000;

}  // namespace

TrainingSchedule::TrainingSchedule(const TrainerConfig& trainer)
    : trainer_(trainer) {}

int TrainingSchedule::iterations() const {
  return dagger() ? trainer_.dagger_iterations : 1;
}

int TrainingSchedule::epochsPerIteration() const {
  return dagger() ? trainer_.dagger_epochs : trainer_.epochs;
}

double TrainingSchedule::beta(int iteration) const {
  if (!dagger()) return 1.0;
  const double p = trainer_.dagger_beta;
  if (p == 0.0) return 0.0;  // VLN-CE: 0^0 would be 1
  return std::pow(p, iteration + (trainer_.fine_tune_dagger ? 1 : 0));
}

double roundLearningRate(double rate, const std::string& schedule, int epoch,
                         int epochs) {
  if (schedule != "cosine") return rate;
  const double progress = static_cast<double>(epoch) / std::max(1, epochs);
  return rate * 0.5 * (1.0 + std::cos(M_PI * progress));
}

double TrainingSchedule::learningRate(int iteration, int epoch) const {
  return roundLearningRate(trainer_.lr * std::pow(trainer_.lr_decay, iteration),
                           trainer_.lr_schedule, epoch, epochsPerIteration());
}

std::vector<size_t> TrainingSchedule::roundEpisodes(int iteration,
                                                    size_t poolSize) const {
  std::vector<size_t> order(poolSize);
  for (size_t i = 0; i < poolSize; ++i) order[i] = i;
  if (!dagger() || poolSize == 0) return order;
  std::mt19937_64 rng(
      common::deriveSeed(static_cast<uint64_t>(trainer_.seed),
                         kRoundStream + static_cast<uint64_t>(iteration)));
  common::deterministicShuffle(order, rng);
  size_t count = static_cast<size_t>(trainer_.dagger_episodes);
  if (beta(iteration) >= 1.0) count = std::min(count, poolSize);
  std::vector<size_t> slots(count);
  for (size_t k = 0; k < count; ++k) slots[k] = order[k % poolSize];
  return slots;
}

size_t TrainingSchedule::smallestRound(size_t poolSize) const {
  if (!dagger()) return poolSize;
  size_t smallest = static_cast<size_t>(trainer_.dagger_episodes);
  for (int n = 0; n < trainer_.dagger_iterations; ++n)
    if (beta(n) >= 1.0) smallest = std::min(smallest, poolSize);
  return smallest;
}

std::vector<ScheduledIteration> TrainingSchedule::remaining(
    int iterationsDone, int epochsDone) const {
  std::vector<ScheduledIteration> todo;
  const int perIteration = epochsPerIteration();
  for (int n = iterationsDone; n < iterations(); ++n) {
    ScheduledIteration iteration;
    iteration.iteration = n;
    const int first = n == iterationsDone ? epochsDone : 0;
    iteration.collect = first == 0;
    for (int e = first; e < perIteration; ++e) {
      ScheduledEpoch s;
      s.epoch = e;
      const bool last = e + 1 == perIteration;
      // teacher forcing validates every epoch, DAgger every epoch or only
      // after an iteration's last
      s.evaluate_after =
          trainer_.eval_during_training &&
          (!dagger() || last || trainer_.evaluate_every == "epoch");
      // teacher forcing counts epochs only; DAgger moves on to the next
      // iteration after its last epoch
      s.iterations_done = dagger() && last ? n + 1 : n;
      s.epochs_done = dagger() && last ? 0 : e + 1;
      iteration.epochs.push_back(s);
    }
    todo.push_back(iteration);
  }
  return todo;
}

}  // namespace vln::train
