// TrainingSchedule: the order of collection, epochs, checkpoints and
// evaluations, the DAgger betas and round episodes, and resuming, without a
// simulator.

#include "train/TrainingSchedule.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>
#include <string>

namespace vln::train {
namespace {

using ::testing::ElementsAre;

// "collect 0, e0 eval -> (0,1), ..." for compact expectations
std::vector<std::string> describe(const std::vector<ScheduledIteration>& todo) {
  std::vector<std::string> out;
  for (const ScheduledIteration& it : todo) {
    if (it.collect) out.push_back("collect " + std::to_string(it.iteration));
    for (const ScheduledEpoch& e : it.epochs)
      out.push_back("train " + std::to_string(it.iteration) + "." +
                    std::to_string(e.epoch) +
                    (e.evaluate_after ? " eval" : "") + " -> (" +
                    std::to_string(e.iterations_done) + "," +
                    std::to_string(e.epochs_done) + ")");
  }
  return out;
}

TrainerConfig teacherForcing(int epochs) {
  TrainerConfig t;
  t.dagger_iterations = 0;
  t.epochs = epochs;
  return t;
}

// evaluating after each iteration's last epoch only, unless told
TrainerConfig dagger(int iterations, int epochs, int episodes, double beta,
                     const std::string& evaluateEvery = "iteration") {
  TrainerConfig t;
  t.evaluate_every = evaluateEvery;
  t.dagger_iterations = iterations;
  t.dagger_epochs = epochs;
  t.dagger_episodes = episodes;
  t.dagger_beta = beta;
  return t;
}

TEST(TrainingScheduleTest, TeacherForcingCollectsOnceAndValidatesEveryEpoch) {
  const TrainingSchedule s(teacherForcing(3));
  EXPECT_FALSE(s.dagger());
  EXPECT_EQ(s.iterations(), 1);
  EXPECT_EQ(s.beta(0), 1.0);
  EXPECT_THAT(
      describe(s.remaining(0, 0)),
      ElementsAre("collect 0", "train 0.0 eval -> (0,1)",
                  "train 0.1 eval -> (0,2)", "train 0.2 eval -> (0,3)"));
}

TEST(TrainingScheduleTest, DaggerValidatesAfterEachIterationsLastEpoch) {
  const TrainingSchedule s(dagger(2, 2, 10, 0.75));
  EXPECT_THAT(describe(s.remaining(0, 0)),
              ElementsAre("collect 0", "train 0.0 -> (0,1)",
                          "train 0.1 eval -> (1,0)", "collect 1",
                          "train 1.0 -> (1,1)", "train 1.1 eval -> (2,0)"));
}

// VLN-CE evaluates every checkpoint it saves, one per epoch
TEST(TrainingScheduleTest, DaggerCanValidateAfterEveryEpochAsVlnCe) {
  EXPECT_EQ(TrainerConfig{}.evaluate_every, "epoch");
  const TrainingSchedule s(dagger(2, 2, 10, 0.75, "epoch"));
  EXPECT_THAT(describe(s.remaining(0, 0)),
              ElementsAre("collect 0", "train 0.0 eval -> (0,1)",
                          "train 0.1 eval -> (1,0)", "collect 1",
                          "train 1.0 eval -> (1,1)",
                          "train 1.1 eval -> (2,0)"));
}

TEST(TrainingScheduleTest, WithoutValidationNothingIsEvaluated) {
  TrainerConfig t = dagger(2, 1, 10, 0.5);
  t.eval_during_training = false;
  EXPECT_THAT(describe(TrainingSchedule(t).remaining(0, 0)),
              ElementsAre("collect 0", "train 0.0 -> (1,0)", "collect 1",
                          "train 1.0 -> (2,0)"));
}

TEST(TrainingScheduleTest,
     ResumingSkipsWhatIsDoneAndCollectsOnlyAtARoundsStart) {
  const TrainingSchedule tf(teacherForcing(3));
  EXPECT_THAT(describe(tf.remaining(0, 2)),
              ElementsAre("train 0.2 eval -> (0,3)"));
  EXPECT_TRUE(describe(tf.remaining(0, 3)).empty());
  const TrainingSchedule da(dagger(3, 2, 10, 0.75));
  // mid-iteration: no collection, the rest of its epochs, then the next
  EXPECT_THAT(describe(da.remaining(1, 1)),
              ElementsAre("train 1.1 eval -> (2,0)", "collect 2",
                          "train 2.0 -> (2,1)", "train 2.1 eval -> (3,0)"));
  // at an iteration's start its round is (re)collected: the collector
  // skips the episodes already stored
  EXPECT_THAT(describe(da.remaining(2, 0)),
              ElementsAre("collect 2", "train 2.0 -> (2,1)",
                          "train 2.1 eval -> (3,0)"));
  EXPECT_TRUE(da.remaining(3, 0).empty());
}

TEST(TrainingScheduleTest, TeacherForcingWithoutEpochsOnlyCollects) {
  EXPECT_THAT(describe(TrainingSchedule(teacherForcing(0)).remaining(0, 0)),
              ElementsAre("collect 0"));
}

TEST(TrainingScheduleTest, BetaIsTheBasesPowerAsVlnCe) {
  const TrainingSchedule s(dagger(4, 1, 10, 0.75));
  EXPECT_EQ(s.beta(0), 1.0);
  EXPECT_DOUBLE_EQ(s.beta(1), 0.75);
  EXPECT_DOUBLE_EQ(s.beta(3), 0.75 * 0.75 * 0.75);
  // DA*: one power more, the first round already mixes in the policy
  TrainerConfig star = dagger(4, 1, 10, 0.75);
  star.fine_tune_dagger = true;
  EXPECT_DOUBLE_EQ(TrainingSchedule(star).beta(0), 0.75);
  EXPECT_DOUBLE_EQ(TrainingSchedule(star).beta(2), 0.75 * 0.75 * 0.75);
  // 0^0 would be 1: VLN-CE lets the policy drive from the start
  EXPECT_EQ(TrainingSchedule(dagger(2, 1, 10, 0.0)).beta(0), 0.0);
}

TEST(TrainingScheduleTest, LearningRateDecaysPerIteration) {
  TrainerConfig t = dagger(3, 1, 10, 0.75);
  t.lr = 1e-3;
  EXPECT_EQ(TrainingSchedule(t).learningRate(0, 0), 1e-3);
  EXPECT_EQ(TrainingSchedule(t).learningRate(2, 0), 1e-3);  // constant
  t.lr_decay = 0.5;
  const TrainingSchedule decaying(t);
  EXPECT_EQ(decaying.learningRate(0, 0), 1e-3);
  EXPECT_DOUBLE_EQ(decaying.learningRate(1, 0), 5e-4);
  EXPECT_DOUBLE_EQ(decaying.learningRate(2, 0), 2.5e-4);
}

TEST(TrainingScheduleTest, CosineScheduleAnnealsEachRoundsEpochs) {
  TrainerConfig t = dagger(2, 4, 10, 0.75);
  t.lr = 1e-3;
  t.lr_decay = 0.5;
  EXPECT_EQ(TrainingSchedule(t).learningRate(1, 3), 5e-4);  // constant
  t.lr_schedule = "cosine";
  const TrainingSchedule cosine(t);
  // epoch e of 4 at (1 + cos(pi e / 4)) / 2 of its round's rate
  EXPECT_DOUBLE_EQ(cosine.learningRate(0, 0), 1e-3);
  EXPECT_DOUBLE_EQ(cosine.learningRate(0, 1), 1e-3 * (2 + std::sqrt(2.0)) / 4);
  EXPECT_DOUBLE_EQ(cosine.learningRate(0, 2), 5e-4);
  EXPECT_DOUBLE_EQ(cosine.learningRate(0, 3), 1e-3 * (2 - std::sqrt(2.0)) / 4);
  // the next round starts again from its own (decayed) rate
  EXPECT_DOUBLE_EQ(cosine.learningRate(1, 0), 5e-4);
  EXPECT_DOUBLE_EQ(cosine.learningRate(1, 2), 2.5e-4);
  // teacher forcing anneals over trainer.epochs
  TrainerConfig tf = teacherForcing(8);
  tf.lr = 1e-3;
  tf.lr_schedule = "cosine";
  EXPECT_DOUBLE_EQ(TrainingSchedule(tf).learningRate(0, 4), 5e-4);
}

TEST(TrainingScheduleTest, TeacherForcingRunsThePoolInOrder) {
  EXPECT_THAT(TrainingSchedule(teacherForcing(1)).roundEpisodes(0, 4),
              ElementsAre(0u, 1u, 2u, 3u));
}

TEST(TrainingScheduleTest, DaggerRoundsShuffleAndRepeatThePool) {
  const TrainingSchedule s(dagger(3, 1, 10, 0.5));
  // beta = 1 (round 0): each episode at most once
  const auto first = s.roundEpisodes(0, 4);
  EXPECT_EQ(first.size(), 4u);
  EXPECT_EQ(std::set<size_t>(first.begin(), first.end()),
            (std::set<size_t>{0, 1, 2, 3}));
  // beta < 1: dagger_episodes slots, the shuffled pool repeated
  const auto second = s.roundEpisodes(1, 4);
  ASSERT_EQ(second.size(), 10u);
  for (size_t k = 4; k < second.size(); ++k)
    EXPECT_EQ(second[k], second[k - 4]);
  // rounds differ and depend on the seed only
  EXPECT_NE(s.roundEpisodes(1, 50), s.roundEpisodes(2, 50));
  EXPECT_EQ(s.roundEpisodes(1, 50),
            TrainingSchedule(dagger(3, 1, 10, 0.5)).roundEpisodes(1, 50));
  TrainerConfig reseeded = dagger(3, 1, 10, 0.5);
  reseeded.seed = 1;
  EXPECT_NE(TrainingSchedule(reseeded).roundEpisodes(1, 50),
            s.roundEpisodes(1, 50));
  EXPECT_EQ(s.smallestRound(4), 4u);
  EXPECT_EQ(s.smallestRound(40), 10u);
}

}  // namespace
}  // namespace vln::train
