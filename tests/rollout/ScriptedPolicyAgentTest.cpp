// ScriptedPolicyAgent runs a models::exportPolicy() archive and chooses the
// same actions as PolicyAgent on the module that was exported.

#include "rollout/ScriptedPolicyAgent.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>

#include "models/Export.h"
#include "models/WaypointExport.h"
#include "rollout/Evaluator.h"
#include "rollout/PolicyAgent.h"
#include "rollout/RolloutTestPolicy.h"
#include "rollout/RolloutTestWorld.h"

namespace vln::rollout {
namespace {

using test::rolloutTestWorld;
using ::testing::HasSubstr;

std::vector<std::vector<int>> actionsOf(
    Agent& agent, int numEnvs, const std::vector<data::Episode>& episodes) {
  const auto& w = rolloutTestWorld();
  VectorEnv envs(numEnvs, w.sim, w.task, std::make_shared<SceneCache>(w.sim),
                 2);
  const EvaluationResult r =
      evaluateEpisodes(agent, envs, episodes, nullptr, EvalConfig{});
  std::vector<std::vector<int>> actions;
  for (const auto& e : r.episodes) actions.push_back(e.record.actions);
  return actions;
}

TEST(ScriptedPolicyAgentTest, ChoosesTheSameActionsAsThePolicyItExports) {
  const auto& w = rolloutTestWorld();
  const std::vector<data::Episode> episodes(w.episodes.begin(),
                                            w.episodes.begin() + 4);
  vln::test::TempDir dir;
  // seeds whose random policies change actions within episodes
  for (auto [type, seed] : {std::pair{models::PolicyType::kCma, 13},
                            std::pair{models::PolicyType::kSeq2Seq, 25}}) {
    SCOPED_TRACE(models::policyName(type));
    const auto model =
        test::tinyAgentModel(type, static_cast<uint64_t>(seed), /*gain=*/60.0);
    const auto file = dir / (std::string(models::policyName(type)) + ".pt");
    models::exportPolicy(*model.policy, model.encoder.ptr().get(), file);

    for (bool sample : {false, true}) {
      SCOPED_TRACE(sample ? "sampled" : "argmax");
      PolicyAgent reference(model.policy, model.encoder, 3, sample, /*seed=*/5,
                            200);
      ScriptedPolicyAgent scripted(file, 3, sample, /*seed=*/5, 200);
      EXPECT_EQ(scripted.config(), model.policy->config());
      const auto expected = actionsOf(reference, 3, episodes);
      EXPECT_EQ(actionsOf(scripted, 3, episodes), expected);
      // long, varied episodes, so the comparison means something
      size_t steps = 0, mostKinds = 0;
      for (const auto& a : expected) {
        steps += a.size();
        mostKinds =
            std::max(mostKinds, std::set<int>(a.begin(), a.end()).size());
      }
      EXPECT_GT(steps, 100u);
      EXPECT_GE(mostKinds, 2u);
    }
  }
}

TEST(ScriptedPolicyAgentTest, AblatedModalitiesAndInstructionRun) {
  const auto& w = rolloutTestWorld();
  const std::vector<data::Episode> episodes(w.episodes.begin(),
                                            w.episodes.begin() + 3);
  vln::test::TempDir dir;
  models::ModelConfig config = test::tinyModel(models::PolicyType::kCma);
  config.no_rgb = true;
  config.no_instruction = true;
  torch::manual_seed(3);
  auto policy = models::makePolicy(config);
  models::ObservationEncoder encoder(config);
  models::exportPolicy(*policy, encoder.get(), dir / "ablated.pt");
  PolicyAgent reference(policy, encoder, 2, false, 0, 200);
  ScriptedPolicyAgent scripted(dir / "ablated.pt", 2, false, 0, 200);
  EXPECT_EQ(actionsOf(scripted, 2, episodes),
            actionsOf(reference, 2, episodes));
}

TEST(ScriptedPolicyAgentTest, BadArchivesAreNamed) {
  vln::test::TempDir dir;
  EXPECT_THAT(
      [&] { ScriptedPolicyAgent a(dir / "missing.pt", 1, false, 0, 200); },
      ::testing::Throws<std::runtime_error>(::testing::Property(
          &std::exception::what, HasSubstr("missing.pt' does not exist"))));
  const auto junk = vln::test::writeText(dir / "junk.pt", "not an archive");
  EXPECT_THAT([&] { ScriptedPolicyAgent a(junk, 1, false, 0, 200); },
              ::testing::Throws<std::runtime_error>(::testing::Property(
                  &std::exception::what,
                  HasSubstr("junk.pt' is not an intact zip archive"))));
  // an export without encoders takes features, not observations
  const auto model = test::tinyAgentModel(models::PolicyType::kSeq2Seq, 2);
  models::exportPolicy(*model.policy, nullptr, dir / "features.pt");
  EXPECT_THAT(
      [&] { ScriptedPolicyAgent a(dir / "features.pt", 1, false, 0, 200); },
      ::testing::Throws<std::invalid_argument>(
          ::testing::Property(&std::exception::what,
                              HasSubstr("exported without its RGB encoder"))));
  // a waypoint policy's archive takes panoramas and candidates
  models::WaypointCmaPolicyImpl waypoint(model.policy->config(), /*numViews=*/4,
                                         /*rgbFeatures=*/8,
                                         /*depthFeatures=*/8);
  models::exportWaypointPolicy(waypoint, nullptr, dir / "waypoint.pt");
  EXPECT_THAT(
      [&] { ScriptedPolicyAgent a(dir / "waypoint.pt", 1, false, 0, 200); },
      ::testing::Throws<std::invalid_argument>(::testing::Property(
          &std::exception::what, HasSubstr("is a waypoint policy export"))));
  // a tensor file is an archive without model_config
  torch::jit::Module plain("plain");
  plain.register_buffer("x", torch::zeros({1}));
  plain.save((dir / "plain.pt").string());
  EXPECT_THAT(
      [&] { ScriptedPolicyAgent a(dir / "plain.pt", 1, false, 0, 200); },
      ::testing::Throws<std::invalid_argument>(
          ::testing::Property(&std::exception::what,
                              HasSubstr("has no 'model_config' attribute"))));
}

}  // namespace
}  // namespace vln::rollout
