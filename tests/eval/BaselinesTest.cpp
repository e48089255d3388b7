#include "eval/Baselines.h"

#include <map>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/Json.h"
#include "support/TestPaths.h"

namespace vln::eval {
namespace {

using ::testing::HasSubstr;

std::vector<sim::Action> rollout(BaselineAgent& agent, std::string_view id,
                                 int steps) {
  agent.reset(id);
  std::vector<sim::Action> out;
  for (int i = 0; i < steps; ++i) out.push_back(agent.act());
  return out;
}

TEST(BaselinesTest, ActionDistributionCountsEveryAction) {
  const std::vector<std::vector<int>> gt{{1, 1, 2, 0}, {3, 1, 0}};
  const ActionDistribution d = actionDistribution(gt);
  EXPECT_DOUBLE_EQ(d[0], 2.0 / 7.0);
  EXPECT_DOUBLE_EQ(d[1], 3.0 / 7.0);
  EXPECT_DOUBLE_EQ(d[2], 1.0 / 7.0);
  EXPECT_DOUBLE_EQ(d[3], 1.0 / 7.0);

  const std::vector<std::vector<int>> bad{{1, 1}, {1, 4}};
  EXPECT_THAT([&] { actionDistribution(bad); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr(
                  "sequence 1 action 1 is not an action code 0..3, got 4")));
  const std::vector<std::vector<int>> empty{{}};
  EXPECT_THAT([&] { actionDistribution(empty); },
              ::testing::Throws<std::invalid_argument>());
}

TEST(BaselinesTest, ActionDistributionOfSharedGroundTruth) {
  const auto file = test::sharedFixturesPath() /
                    "r2r_vlnce_v1-3_preprocessed/val_seen_sample_gt.json.gz";
  if (!std::filesystem::exists(file)) GTEST_SKIP() << file << " absent";
  std::vector<std::vector<int>> sequences;
  const nlohmann::json gt = common::readJsonFile(file);
  for (const auto& [id, entry] : gt.items())
    sequences.push_back(entry.at("actions").get<std::vector<int>>());
  const ActionDistribution d = actionDistribution(sequences);
  // Calculated from the same file with Python's collections.Counter:
  // 12 STOP, 510 MOVE_FORWARD, 171 TURN_LEFT, 147 TURN_RIGHT of 840
  EXPECT_DOUBLE_EQ(d[0], 12.0 / 840.0);
  EXPECT_DOUBLE_EQ(d[1], 510.0 / 840.0);
  EXPECT_DOUBLE_EQ(d[2], 171.0 / 840.0);
  EXPECT_DOUBLE_EQ(d[3], 147.0 / 840.0);
}

TEST(BaselinesTest, HandcraftedForwardStepsFromPathLengths) {
  // the paper's number: 9.27 m mean train path / 0.25 m steps = 37
  EXPECT_EQ(handcraftedForwardSteps(std::vector<double>{9.27}, 0.25), 37);
  EXPECT_EQ(handcraftedForwardSteps(std::vector<double>{9.0, 9.54}, 0.25), 37);
  EXPECT_EQ(handcraftedForwardSteps(std::vector<double>{1.0, 2.0}, 0.5), 3);
  EXPECT_THAT([] { handcraftedForwardSteps({}, 0.25); },
              ::testing::Throws<std::invalid_argument>());
  EXPECT_THAT(
      [] { handcraftedForwardSteps(std::vector<double>{1.0}, 0.0); },
      ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("step size")));
}

TEST(BaselinesTest, RandomAgentMatchesItsDistribution) {
  RandomAgent agent(kPaperActionDistribution, /*seed=*/5);
  std::array<int64_t, 4> counts{};
  int64_t total = 0;
  for (int e = 0; e < 2000; ++e) {
    for (sim::Action a : rollout(agent, std::to_string(e), 50)) {
      ++counts[static_cast<int>(a)];
      ++total;
    }
  }
  // 100k draws: the standard error of a frequency is <= 0.0016
  for (int a = 0; a < 4; ++a)
    EXPECT_NEAR(static_cast<double>(counts[a]) / total,
                kPaperActionDistribution[a], 0.008)
        << "action " << a;
}

TEST(BaselinesTest, RandomAgentNormalisesAndSkipsZeroMass) {
  RandomAgent agent({0.0, 2.0, 0.0, 2.0}, /*seed=*/1);
  EXPECT_DOUBLE_EQ(agent.probabilities()[1], 0.5);
  int forward = 0;
  for (sim::Action a : rollout(agent, "x", 4000)) {
    EXPECT_TRUE(a == sim::Action::kMoveForward || a == sim::Action::kTurnRight);
    forward += a == sim::Action::kMoveForward;
  }
  EXPECT_NEAR(forward / 4000.0, 0.5, 0.04);
  EXPECT_THAT(
      [] {
        RandomAgent({0, 0, 0, 0});
      },
      ::testing::Throws<std::invalid_argument>());
  EXPECT_THAT(
      [] {
        RandomAgent({0.5, -0.1, 0.3, 0.3});
      },
      ::testing::ThrowsMessage<std::invalid_argument>(
          HasSubstr("probability of action 1")));
}

TEST(BaselinesTest, AgentsAreDeterministicPerEpisode) {
  RandomAgent a(kPaperActionDistribution, 9), b(kPaperActionDistribution, 9);
  // b runs other episodes first: episode "17" still gets the same actions
  rollout(b, "3", 20);
  EXPECT_EQ(rollout(a, "17", 60), rollout(b, "17", 60));
  EXPECT_NE(rollout(a, "17", 60), rollout(a, "18", 60));
  RandomAgent otherSeed(kPaperActionDistribution, 10);
  EXPECT_NE(rollout(a, "17", 60), rollout(otherSeed, "17", 60));

  HandcraftedAgent h1(37, 24, 3), h2(37, 24, 3);
  h2.reset("a");
  h1.reset("b");
  h2.reset("b");
  EXPECT_EQ(h1.turns(), h2.turns());
}

TEST(BaselinesTest, HandcraftedAgentFollowsTheRule) {
  HandcraftedAgent agent(/*forwardSteps=*/37, kHandcraftedMaxTurns, /*seed=*/2);
  std::map<int, int> turnCounts;
  const int episodes = 2500;
  for (int e = 0; e < episodes; ++e) {
    const auto actions = rollout(agent, "ep" + std::to_string(e), 24 + 37 + 3);
    const int k = agent.turns();
    ++turnCounts[k];
    // k x TURN_RIGHT, 37 x MOVE_FORWARD, then STOP forever
    for (int i = 0; i < static_cast<int>(actions.size()); ++i) {
      const sim::Action expected = i < k        ? sim::Action::kTurnRight
                                   : i < k + 37 ? sim::Action::kMoveForward
                                                : sim::Action::kStop;
      ASSERT_EQ(actions[i], expected) << "episode " << e << " step " << i;
    }
  }
  // uniform over 0..24: 100 expected per value (sd ~9.8)
  EXPECT_EQ(turnCounts.begin()->first, 0);
  EXPECT_EQ(turnCounts.rbegin()->first, 24);
  EXPECT_EQ(turnCounts.size(), 25u);
  double mean = 0.0;
  for (auto [k, n] : turnCounts) {
    EXPECT_GT(n, 55) << k;
    EXPECT_LT(n, 145) << k;
    mean += static_cast<double>(k) * n / episodes;
  }
  EXPECT_NEAR(mean, 12.0, 0.5);
}

TEST(BaselinesTest, MaxTurnsCoverTheCircleForAnyTurnAngle) {
  EXPECT_EQ(handcraftedMaxTurns(15.0), kHandcraftedMaxTurns);  // VLN-CE's 24
  EXPECT_EQ(handcraftedMaxTurns(30.0), 12);                    // RxR-Habitat
  EXPECT_EQ(handcraftedMaxTurns(10.0), 36);
  EXPECT_EQ(handcraftedMaxTurns(45.0), 8);
  EXPECT_EQ(handcraftedMaxTurns(100.0), 3);  // int(3.6)
  EXPECT_EQ(handcraftedMaxTurns(360.0), 1);
  for (double bad : {0.0, -15.0, 361.0})
    EXPECT_THAT([bad] { handcraftedMaxTurns(bad); },
                ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("turn angle")));
}

TEST(BaselinesTest, FactoryBuildsByName) {
  auto random = makeBaseline("random", kPaperActionDistribution, 37, 24, 1);
  EXPECT_EQ(random->name(), "random");
  auto hand = makeBaseline("handcrafted", kPaperActionDistribution, 5, 24, 1);
  // with at most 2 turns, every episode's draw is 0, 1 or 2
  auto few = makeBaseline("handcrafted", kPaperActionDistribution, 5, 2, 1);
  for (int e = 0; e < 50; ++e) {
    few->reset("e" + std::to_string(e));
    EXPECT_LE(dynamic_cast<HandcraftedAgent&>(*few).turns(), 2);
  }
  hand->reset("e");
  const int turns = dynamic_cast<HandcraftedAgent&>(*hand).turns();
  for (int i = 0; i < turns; ++i) hand->act();
  for (int i = 0; i < 5; ++i) EXPECT_EQ(hand->act(), sim::Action::kMoveForward);
  EXPECT_EQ(hand->act(), sim::Action::kStop);
  EXPECT_THAT([] { makeBaseline("greedy", kPaperActionDistribution, 37, 24, 1); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("unknown baseline 'greedy'")));
}

}  // namespace
}  // namespace vln::eval
