// WaypointAgent: the oracle-driven agent reaches the goals and records
// consistent decisions, batching never changes an episode, the decision cap
// STOPs, the STOP bias moves the policy's stops, teleporting
// (waypoint_agent.execution) takes one recorded step per waypoint with teleport
// labels and the caps, recorded decisions batch into padded training tensors,
// and decisions mirror (panorama views, headings, the words left and right) for
// mirrored replays; with view_labels the policy reads the views' true labels.

#include "rollout/WaypointAgent.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "rollout/Evaluator.h"
#include "rollout/RolloutTestPolicy.h"
#include "rollout/RolloutTestWorld.h"
#include "sim/NavMesh.h"
#include "sim/Panorama.h"
#include "waypoint/WaypointApproach.h"
#include "world/ViewLabels.h"

namespace vln::rollout {
namespace {

using test::rolloutTestWorld;

int64_t flat(const models::FeatureShape& s) { return s[0] * s[1] * s[2]; }

struct TinyWaypointAgent {
  std::shared_ptr<models::WaypointCmaPolicyImpl> policy;
  models::ObservationEncoder encoder{nullptr};
  WaypointAgentConfig config;
  sim::PanoramaConfig panorama;
};

TinyWaypointAgent tinyWaypointAgent(uint64_t seed) {
  torch::manual_seed(seed);
  TinyWaypointAgent t;
  const models::ModelConfig model = test::tinyModel(models::PolicyType::kCma);
  t.policy = std::make_shared<models::WaypointCmaPolicyImpl>(
      model, 12, flat(models::rgbFeatureShape(model)),
      flat(models::depthFeatureShape(model)));
  t.encoder = models::ObservationEncoder(model);
  t.config.candidates = "depth_baseline";
  t.panorama.rgb = {32, 32, 90.0f, 1.25f};
  t.panorama.depth.camera = {32, 32, 90.0f, 1.25f};
  return t;
}

std::unique_ptr<WaypointAgent> makeAgent(const TinyWaypointAgent& t,
                                         int numEnvs, bool sample) {
  return std::make_unique<WaypointAgent>(
      t.policy, t.encoder, models::WaypointPredictor{nullptr}, CandidateNms{},
      t.config, t.panorama, rolloutTestWorld().sim.agent, numEnvs, sample,
      /*seed=*/7, /*maxInstructionLength=*/200);
}

sim::TaskConfig longTask() {
  sim::TaskConfig task = rolloutTestWorld().task;
  task.max_episode_steps = 500;
  return task;
}

EvaluationResult run(WaypointAgent& agent,
                     const std::vector<data::Episode>& episodes, int numEnvs,
                     int threads) {
  const auto& w = rolloutTestWorld();
  VectorEnv envs(numEnvs, w.sim, longTask(),
                 std::make_shared<SceneCache>(w.sim), threads);
  return evaluateEpisodes(agent, envs, episodes, nullptr, EvalConfig{});
}

TEST(WaypointAgentTest, FollowingTheOracleReachesTheGoalsAndRecordsLabels) {
  const auto& w = rolloutTestWorld();
  const TinyWaypointAgent t = tinyWaypointAgent(1);
  int successes = 0;
  for (const data::Episode& episode : w.episodes) {
    auto agent = makeAgent(t, 1, false);
    agent->collect({/*beta=*/1.0, /*sample=*/true, /*seed=*/3});
    const EvaluationResult r = run(*agent, {episode}, 1, 1);
    successes += r.episodes.front().metrics.success > 0.5 ? 1 : 0;
    const std::vector<WaypointDecision> decisions = agent->takeDecisions(0);
    ASSERT_FALSE(decisions.empty());
    EXPECT_EQ(static_cast<int>(decisions.size()), agent->decisions(0));
    for (size_t i = 0; i < decisions.size(); ++i) {
      const WaypointDecision& d = decisions[i];
      EXPECT_EQ(d.taken, d.label);  // beta 1: the oracle drives
      EXPECT_LE(d.candidates.size(), 5u);
      EXPECT_LE(d.label, static_cast<int>(d.candidates.size()));
      EXPECT_EQ(d.rgb.sizes(), (std::vector<int64_t>{12, d.rgb.size(1)}));
      EXPECT_EQ(d.depth.scalar_type(), torch::kHalf);
      if (i == 0)
        EXPECT_EQ(d.prev_distance, 0.0f);
      else
        EXPECT_GT(d.prev_distance, 0.0f);
    }
    // the evaluator's record carries the decisions for maps
    const auto& choices = r.episodes.front().record.waypoint_choices;
    ASSERT_EQ(choices.size(), decisions.size());
    for (size_t i = 0; i < choices.size(); ++i) {
      EXPECT_EQ(choices[i].chosen, decisions[i].taken - 1);
      EXPECT_EQ(choices[i].candidates.size(), decisions[i].candidates.size());
    }
    // the episode ended by the oracle's STOP, its last decision
    EXPECT_EQ(decisions.back().label, 0);
    EXPECT_EQ(r.episodes.front().record.actions.back(),
              static_cast<int>(sim::Action::kStop));
  }
  EXPECT_GE(successes, 8) << "of " << w.episodes.size();
}

TEST(WaypointAgentTest, BatchingDoesNotChangeAnEpisode) {
  const auto& w = rolloutTestWorld();
  const TinyWaypointAgent t = tinyWaypointAgent(2);
  auto one = makeAgent(t, 1, /*sample=*/true);
  auto four = makeAgent(t, 4, /*sample=*/true);
  const EvaluationResult a = run(*one, w.episodes, 1, 1);
  const EvaluationResult b = run(*four, w.episodes, 4, 2);
  ASSERT_EQ(a.episodes.size(), b.episodes.size());
  size_t longest = 0;
  for (size_t i = 0; i < a.episodes.size(); ++i) {
    EXPECT_EQ(a.episodes[i].record.actions, b.episodes[i].record.actions)
        << "episode " << i;
    longest = std::max(longest, a.episodes[i].record.actions.size());
  }
  EXPECT_GT(longest, 10u);  // the random policy walks somewhere
}

// an evaluated decision carries the goal oracle's verdict on the same
// candidates: its choice is the candidate that ends nearest the goal, a
// STOP without plans only within its stop distance; without a goal (a
// hidden test split) there is none
TEST(WaypointAgentTest, EvaluationRecordsTheGoalOraclesVerdict) {
  const auto& w = rolloutTestWorld();
  const TinyWaypointAgent t = tinyWaypointAgent(5);
  auto agent = makeAgent(t, 2, /*sample=*/true);
  const EvaluationResult r = run(*agent, w.episodes, 2, 2);
  size_t candidates = 0;
  for (size_t i = 0; i < r.episodes.size(); ++i) {
    const sim::NavMesh& navmesh = w.scene->navmesh();  // one scene
    const Vec3f goal = w.episodes[i].goals.front().position;
    for (const WaypointChoice& c : r.episodes[i].record.waypoint_choices) {
      ASSERT_GE(c.oracle, -1);
      if (c.end_distances.empty()) {
        EXPECT_EQ(c.oracle, -1);
        EXPECT_LE(navmesh.geodesicDistance(c.position, goal),
                  t.config.approach.stop_distance + 1e-4f);
        continue;
      }
      ASSERT_EQ(c.end_distances.size(), c.candidates.size());
      candidates += c.candidates.size();
      if (c.oracle >= 0) {
        EXPECT_EQ(
            c.end_distances[static_cast<size_t>(c.oracle)],
            *std::min_element(c.end_distances.begin(), c.end_distances.end()));
      }
    }
  }
  EXPECT_GT(candidates, 0u);

  data::Episode hidden = w.episodes.front();
  hidden.goals.clear();
  auto blind = makeAgent(t, 1, /*sample=*/true);
  const EvaluationResult h = run(*blind, {hidden}, 1, 1);
  ASSERT_FALSE(h.episodes.front().record.waypoint_choices.empty());
  for (const WaypointChoice& c : h.episodes.front().record.waypoint_choices) {
    EXPECT_EQ(c.oracle, WaypointChoice::kNoOracle);
    EXPECT_TRUE(c.end_distances.empty());
  }
}

TEST(WaypointAgentTest, StopsAfterMaxDecisions) {
  const auto& w = rolloutTestWorld();
  TinyWaypointAgent t = tinyWaypointAgent(3);
  t.config.max_decisions = 2;
  // whatever the random policy picks, the third decision is STOP
  auto agent = makeAgent(t, 2, /*sample=*/true);
  const EvaluationResult r = run(*agent, w.episodes, 2, 2);
  for (const auto& e : r.episodes) {
    EXPECT_EQ(e.record.actions.back(), static_cast<int>(sim::Action::kStop));
    // two approaches of at most 12 turns and 12 steps each, then STOP
    EXPECT_LE(e.record.actions.size(), 2u * 24u + 1u);
  }
}

// waypoint_agent.stop_bias: a large bias makes the policy STOP at its first
// decision, a large negative one never (until the decision cap)
TEST(WaypointAgentTest, StopBiasMovesThePolicysStops) {
  const auto& w = rolloutTestWorld();
  TinyWaypointAgent t = tinyWaypointAgent(4);
  t.config.max_decisions = 3;
  t.config.stop_bias = 20.0;
  auto eager = makeAgent(t, 2, /*sample=*/false);
  for (const auto& e : run(*eager, w.episodes, 2, 2).episodes) {
    EXPECT_EQ(e.record.actions,
              std::vector<int>{static_cast<int>(sim::Action::kStop)});
    ASSERT_EQ(e.record.waypoint_choices.size(), 1u);
    EXPECT_EQ(e.record.waypoint_choices.front().chosen, -1);
  }
  t.config.stop_bias = -20.0;
  auto reluctant = makeAgent(t, 2, /*sample=*/false);
  for (const auto& e : run(*reluctant, w.episodes, 2, 2).episodes) {
    // every decision the policy took moved (one without candidates can
    // only STOP); the cap's STOP is not a decision
    for (const auto& choice : e.record.waypoint_choices) {
      if (!choice.candidates.empty()) {
        EXPECT_GE(choice.chosen, 0);
      }
    }
    EXPECT_GT(e.record.actions.size(), 1u);
  }
}

// waypoint_agent.execution teleport: each chosen waypoint is one TELEPORT
// step that ends where sim::resolveTeleport() puts the agent, and the
// oracle labels by those ends
TEST(WaypointAgentTest, TeleportingOracleTakesOneStepPerWaypoint) {
  const auto& w = rolloutTestWorld();
  TinyWaypointAgent t = tinyWaypointAgent(1);
  t.config.execution = waypoint::Execution::kTeleport;
  SceneCache scenes(w.sim);
  const sim::AgentConfig& body = w.sim.agent;
  int successes = 0, teleports = 0, moved = 0;
  for (const data::Episode& episode : w.episodes) {
    auto agent = makeAgent(t, 1, false);
    agent->collect({/*beta=*/1.0, /*sample=*/true, /*seed=*/3});
    const EvaluationResult r = run(*agent, {episode}, 1, 1);
    const EpisodeRecord& record = r.episodes.front().record;
    successes += r.episodes.front().metrics.success > 0.5 ? 1 : 0;
    const std::vector<WaypointDecision> decisions = agent->takeDecisions(0);
    // one step per decision: a TELEPORT per waypoint, STOP last
    ASSERT_EQ(record.actions.size(), decisions.size());
    ASSERT_EQ(record.positions.size(), decisions.size() + 1);
    EXPECT_EQ(record.steps_taken, static_cast<int>(decisions.size()));
    EXPECT_EQ(record.actions.back(), static_cast<int>(sim::Action::kStop));
    const auto scene = scenes.get(episode.scene_id);
    const sim::NavMesh& navmesh = scene->navmesh();
    double pathLength = 0.0;
    for (size_t i = 0; i < decisions.size(); ++i) {
      const WaypointDecision& d = decisions[i];
      const sim::AgentState state{record.positions[i], record.headings[i],
                                  0.0f};
      // the label is the oracle's under teleporting (recomputed here)
      EXPECT_EQ(d.label,
                1 + waypoint::oracleChoice(navmesh, body, state, d.candidates,
                                           episode.goals.front().position,
                                           t.config.approach,
                                           waypoint::Execution::kTeleport))
          << "decision " << i;
      if (d.taken == 0) continue;
      EXPECT_EQ(record.actions[i], static_cast<int>(sim::Action::kTeleport));
      ++teleports;
      // the recorded position is the resolved teleport's end
      const waypoint::Candidate& c =
          d.candidates[static_cast<size_t>(d.taken - 1)];
      const sim::Teleport expected = sim::resolveTeleport(
          navmesh, state,
          waypoint::teleportTarget(state, c.heading, c.distance));
      EXPECT_EQ(record.positions[i + 1], expected.end.position);
      EXPECT_FLOAT_EQ(record.headings[i + 1], expected.end.heading);
      moved += expected.refused ? 0 : 1;
      pathLength += (record.positions[i + 1] - record.positions[i]).norm();
    }
    // path length: the straight segments between consecutive positions
    EXPECT_NEAR(r.episodes.front().metrics.path_length, pathLength, 1e-3);
  }
  EXPECT_GT(moved, teleports / 2);
  EXPECT_GE(successes, 8) << "of " << w.episodes.size();
}

TEST(WaypointAgentTest, TeleportingRespectsTheDecisionAndStepCaps) {
  const auto& w = rolloutTestWorld();
  TinyWaypointAgent t = tinyWaypointAgent(3);
  t.config.execution = waypoint::Execution::kTeleport;
  t.config.max_decisions = 2;
  auto agent = makeAgent(t, 2, /*sample=*/true);
  const EvaluationResult r = run(*agent, w.episodes, 2, 2);
  for (const auto& e : r.episodes) {
    // at most two teleports, then STOP
    EXPECT_LE(e.record.actions.size(), 3u);
    EXPECT_EQ(e.record.actions.back(), static_cast<int>(sim::Action::kStop));
    for (size_t i = 0; i + 1 < e.record.actions.size(); ++i)
      EXPECT_EQ(e.record.actions[i], static_cast<int>(sim::Action::kTeleport));
  }
  // task.max_episode_steps caps teleports like any step: the oracle needs
  // more than one waypoint for most episodes, and the cap ends them first
  t.config.max_decisions = 15;
  sim::TaskConfig task = rolloutTestWorld().task;
  task.max_episode_steps = 1;
  VectorEnv envs(2, w.sim, task, std::make_shared<SceneCache>(w.sim), 2);
  auto capped = makeAgent(t, 2, /*sample=*/false);
  capped->collect({/*beta=*/1.0, /*sample=*/false, /*seed=*/3});
  const EvaluationResult c =
      evaluateEpisodes(*capped, envs, w.episodes, nullptr, EvalConfig{});
  int unstopped = 0;
  for (const auto& e : c.episodes) {
    EXPECT_EQ(e.record.steps_taken, 1);
    EXPECT_EQ(e.record.positions.size(), 2u);
    if (!e.record.called_stop) {
      ++unstopped;
      EXPECT_EQ(e.record.actions.front(),
                static_cast<int>(sim::Action::kTeleport));
    }
  }
  EXPECT_GT(unstopped, 0);
}

// the default execution walks: low-level actions only, as before the
// teleport option, and the same episodes teleported take other steps
TEST(WaypointAgentTest, WalkingIsTheDefaultAndUsesLowLevelActionsOnly) {
  const auto& w = rolloutTestWorld();
  TinyWaypointAgent t = tinyWaypointAgent(2);
  EXPECT_EQ(t.config.execution, waypoint::Execution::kWalk);
  auto walker = makeAgent(t, 2, /*sample=*/true);
  const EvaluationResult walked = run(*walker, w.episodes, 2, 2);
  t.config.execution = waypoint::Execution::kTeleport;
  auto teleporter = makeAgent(t, 2, /*sample=*/true);
  const EvaluationResult teleported = run(*teleporter, w.episodes, 2, 2);
  size_t walkedSteps = 0, teleportedSteps = 0;
  for (size_t i = 0; i < walked.episodes.size(); ++i) {
    for (int a : walked.episodes[i].record.actions)
      EXPECT_LT(a, sim::kNumActions) << "episode " << i;
    walkedSteps += walked.episodes[i].record.actions.size();
    teleportedSteps += teleported.episodes[i].record.actions.size();
  }
  EXPECT_GT(walkedSteps, 2 * teleportedSteps);
}

TEST(WaypointAgentTest, DecisionsBatchIntoPaddedSequences) {
  auto decision = [](int candidates, int label) {
    WaypointDecision d;
    d.rgb = torch::ones({12, 3}, torch::kHalf);
    d.depth = torch::full({12, 2}, 2.0, torch::kHalf);
    for (int j = 0; j < candidates; ++j)
      d.candidates.push_back(waypoint::candidateAt(10 * j, j, 1.0f));
    d.prev_heading = 0.5f;
    d.prev_distance = 1.0f;
    d.label = label;
    return d;
  };
  const std::vector<WaypointDecision> a = {decision(2, 1), decision(3, 0)};
  const std::vector<WaypointDecision> b = {decision(1, 1)};
  const std::vector<const std::vector<WaypointDecision>*> rows = {&a, &b};
  const WaypointBatch batch = batchDecisions(rows, 4);
  EXPECT_EQ(batch.inputs.rgb.sizes(), (std::vector<int64_t>{2, 2, 12, 3}));
  EXPECT_EQ(batch.inputs.rgb.scalar_type(), torch::kFloat);
  EXPECT_EQ(batch.inputs.candidates.sizes(),
            (std::vector<int64_t>{2, 2, 4, 2}));
  EXPECT_TRUE(torch::equal(batch.labels,
                           torch::tensor({{1, 1}, {0, -1}}, torch::kLong)));
  EXPECT_TRUE(torch::equal(batch.inputs.not_done,
                           torch::tensor({{0.0f, 0.0f}, {1.0f, 0.0f}})));
  EXPECT_EQ(batch.inputs.candidate_mask[1][0].sum().item<int64_t>(), 3);
  EXPECT_EQ(batch.inputs.candidate_mask[1][1].sum().item<int64_t>(), 0);
  EXPECT_FLOAT_EQ(batch.inputs.candidates[0][0][1][1].item<float>(),
                  waypoint::binDistance(1));
  EXPECT_FLOAT_EQ(batch.inputs.depth[1][0][5][1].item<float>(), 2.0f);
  EXPECT_FLOAT_EQ(batch.inputs.depth[1][1][5][1].item<float>(), 0.0f);
  // without accepted choices, the label alone; none on the padding
  EXPECT_TRUE(torch::equal(batch.acceptable,
                           torch::tensor({0, 1, 0, 0, 0, 0, 1, 0, 0, 0,
                                          1, 0, 0, 0, 0, 0, 0, 0, 0, 0},
                                         torch::kBool)
                               .view({2, 2, 5})));
}

TEST(WaypointAgentTest, AcceptedChoicesBatchAsMasks) {
  WaypointDecision d;
  d.depth = torch::ones({12, 2}, torch::kHalf);
  for (int j = 0; j < 3; ++j)
    d.candidates.push_back(waypoint::candidateAt(10 * j, j, 1.0f));
  d.label = 1;
  d.acceptable = 0b1010u;  // candidates 0 and 2
  const std::vector<WaypointDecision> a = {d};
  const std::vector<const std::vector<WaypointDecision>*> rows = {&a};
  EXPECT_TRUE(
      torch::equal(batchDecisions(rows, 3).acceptable,
                   torch::tensor({0, 1, 0, 1}, torch::kBool).view({1, 1, 4})));
  // a bit beyond the slots is refused, as is a label beyond them
  std::vector<WaypointDecision> bad = {d};
  bad[0].acceptable = 1u << 5;
  const std::vector<const std::vector<WaypointDecision>*> badRows = {&bad};
  EXPECT_THROW(batchDecisions(badRows, 3), std::invalid_argument);
  bad[0].acceptable = 0;
  bad[0].label = 4;
  EXPECT_THROW(batchDecisions(badRows, 3), std::invalid_argument);
}

// the mirror image of a panorama: view k looks k * 30 degrees to the left,
// so its mirror is the view as far to the right, flipped left to right
TEST(WaypointMirrorTest, MirroredViewsAreTheOtherSidesFlipped) {
  torch::manual_seed(11);
  const int64_t views = 12;
  const torch::Tensor images =
      torch::randint(0, 256, {2, views, 3, 4, 3}, torch::kUInt8);
  const torch::Tensor mirrored = mirrorPanoramaViews(images);
  ASSERT_EQ(mirrored.sizes(), images.sizes());
  for (int64_t k = 0; k < views; ++k) {
    const int64_t source = (views - k) % views;
    EXPECT_TRUE(
        torch::equal(mirrored.select(1, k), images.select(1, source).flip({2})))
        << "view " << k;
    // the renderer's convention: that source view looks k views to the right
    const float heading = 0.3f;
    const float want = heading - static_cast<float>(k) * 2.0f *
                                     static_cast<float>(M_PI) / views;
    EXPECT_NEAR(std::remainder(
                    sim::panoramaViewHeading(heading, static_cast<int>(source),
                                             static_cast<int>(views)) -
                        want,
                    2.0 * M_PI),
                0.0, 1e-5)
        << "view " << k;
  }
  EXPECT_TRUE(torch::equal(mirrorPanoramaViews(mirrored), images));
  EXPECT_THROW(mirrorPanoramaViews(torch::zeros({12, 3, 4, 3})),
               std::invalid_argument);
}

TEST(WaypointMirrorTest, AMirroredDecisionNegatesHeadingsAndKeepsItsLabel) {
  WaypointDecision d;
  d.rgb = torch::rand({12, 5}).to(torch::kHalf);
  d.depth = torch::rand({12, 4}).to(torch::kHalf);
  d.rgb_mirrored = torch::rand({12, 5}).to(torch::kHalf);
  d.depth_mirrored = torch::rand({12, 4}).to(torch::kHalf);
  d.candidates.resize(2);
  d.candidates[0].heading_bin = 10;
  d.candidates[0].heading = 0.5f;
  d.candidates[0].distance = 1.0f;
  d.candidates[1].heading_bin = 76;
  d.candidates[1].heading = 4.0f;
  d.candidates[1].distance = 2.5f;
  d.prev_heading = -1.2f;
  d.prev_distance = 0.75f;
  d.label = 2;
  d.taken = 1;
  const WaypointDecision m = mirroredDecision(d);
  EXPECT_TRUE(torch::equal(m.rgb, d.rgb_mirrored));
  EXPECT_TRUE(torch::equal(m.depth, d.depth_mirrored));
  ASSERT_EQ(m.candidates.size(), 2u);
  EXPECT_NEAR(m.candidates[0].heading, -0.5f, 1e-6);
  // 4 rad is -2.28 rad; its mirror 2.28 rad
  EXPECT_NEAR(m.candidates[1].heading, 2.0f * static_cast<float>(M_PI) - 4.0f,
              1e-5);
  EXPECT_EQ(m.candidates[1].distance, 2.5f);
  EXPECT_EQ(m.candidates[0].heading_bin, 110);
  EXPECT_EQ(m.candidates[1].heading_bin, 44);
  EXPECT_NEAR(m.prev_heading, 1.2f, 1e-6);
  EXPECT_EQ(m.prev_distance, 0.75f);
  EXPECT_EQ(m.label, 2);
  EXPECT_EQ(m.taken, 1);
  // mirrored twice: the decision again
  const WaypointDecision back = mirroredDecision(m);
  EXPECT_TRUE(torch::equal(back.rgb, d.rgb));
  EXPECT_NEAR(back.candidates[0].heading, 0.5f, 1e-6);
  // a decision collected without its mirrored panorama
  WaypointDecision plain = d;
  plain.rgb_mirrored = torch::Tensor();
  EXPECT_THROW(mirroredDecision(plain), std::invalid_argument);
}

TEST(WaypointMirrorTest, LeftAndRightSwapOnlyInMirroredRows) {
  const torch::Tensor tokens =
      torch::tensor({{5, 7, 9, 0}, {7, 5, 5, 0}}, torch::kLong);
  const torch::Tensor swapped = swapLeftAndRight(tokens, {false, true}, 5, 7);
  EXPECT_TRUE(torch::equal(swapped[0], tokens[0]));
  EXPECT_TRUE(
      torch::equal(swapped[1], torch::tensor({5, 7, 7, 0}, torch::kLong)));
  EXPECT_TRUE(
      torch::equal(tokens[1], torch::tensor({7, 5, 5, 0}, torch::kLong)))
      << "the input is not changed";
  EXPECT_THROW(swapLeftAndRight(tokens, {true}, 5, 7), std::invalid_argument);
}

// collecting with mirror keeps each decision's mirrored features: the
// encoder's features of the mirrored panorama, of the same shape
TEST(WaypointMirrorTest, CollectionKeepsTheMirroredPanoramasFeatures) {
  const auto& w = rolloutTestWorld();
  const TinyWaypointAgent t = tinyWaypointAgent(1);
  for (const bool mirror : {false, true}) {
    auto agent = makeAgent(t, 1, false);
    WaypointCollection how{/*beta=*/1.0, /*sample=*/true, /*seed=*/3};
    how.mirror = mirror;
    agent->collect(how);
    run(*agent, {w.episodes.front()}, 1, 1);
    const std::vector<WaypointDecision> decisions = agent->takeDecisions(0);
    ASSERT_FALSE(decisions.empty());
    for (const WaypointDecision& d : decisions) {
      ASSERT_EQ(d.rgb_mirrored.defined(), mirror);
      ASSERT_EQ(d.depth_mirrored.defined(), mirror);
      if (!mirror) continue;
      EXPECT_EQ(d.rgb_mirrored.sizes(), d.rgb.sizes());
      EXPECT_EQ(d.depth_mirrored.scalar_type(), torch::kHalf);
      EXPECT_FALSE(torch::equal(d.rgb_mirrored, d.rgb));
    }
  }
}

// waypoint_agent.view_labels: the policy's RGB features are the views'
// true labels (world::viewLabelFeatures() where the agent stands), the
// mirrored panorama's are the same views in the mirror's order, and no RGB
// encoder is needed
TEST(WaypointViewLabelsTest, ThePolicyReadsTheViewsLabels) {
  const auto& w = rolloutTestWorld();
  torch::manual_seed(2);
  models::ModelConfig model = test::tinyModel(models::PolicyType::kCma);
  model.no_rgb = false;
  model.rgb_semantic_outputs = static_cast<int>(world::viewLabelSize());
  TinyWaypointAgent t;
  t.policy = std::make_shared<models::WaypointCmaPolicyImpl>(
      model, 12, world::viewLabelSize(),
      flat(models::depthFeatureShape(model)));
  models::ModelConfig depthOnly = model;
  depthOnly.no_rgb = true;
  t.encoder = models::ObservationEncoder(depthOnly);
  t.config.candidates = "depth_baseline";
  t.config.view_labels = true;
  t.panorama.rgb = {32, 32, 90.0f, 1.25f};
  t.panorama.depth.camera = {32, 32, 90.0f, 1.25f};

  auto agent = makeAgent(t, 1, false);
  WaypointCollection how{/*beta=*/1.0, /*sample=*/true, /*seed=*/3};
  how.mirror = true;
  agent->collect(how);
  const data::Episode& episode = w.episodes.front();
  run(*agent, {episode}, 1, 1);
  const std::vector<WaypointDecision> decisions = agent->takeDecisions(0);
  ASSERT_GE(decisions.size(), 2u);

  // the first decision: where the episode starts, facing its start heading
  auto renderer = sim::createRenderer(w.scene->mesh(), w.scene->rayTracer(),
                                      w.sim.renderer);
  sim::AgentState start;
  start.position = decisions.front().position;
  start.heading = episode.startHeading();
  const std::vector<float> expected = world::viewLabelFeatures(
      *renderer, w.scene->semantics(), start, t.panorama,
      static_cast<float>(t.config.view_label_min_fraction));
  const at::Tensor first = decisions.front().rgb.to(torch::kFloat);
  ASSERT_EQ(first.sizes(), (at::IntArrayRef{12, world::viewLabelSize()}));
  EXPECT_TRUE(torch::equal(first.flatten(), torch::tensor(expected)));
  EXPECT_GT(first.sum().item<float>(), 0.0f) << "a furnished house unseen";

  const at::Tensor order = torch::remainder(12 - torch::arange(12), 12);
  for (const WaypointDecision& d : decisions) {
    ASSERT_EQ(d.rgb.sizes(), first.sizes());
    EXPECT_TRUE(torch::equal(d.rgb_mirrored, d.rgb.index_select(0, order)));
  }
}

}  // namespace
}  // namespace vln::rollout
