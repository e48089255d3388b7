// PolicyAgent: batching never changes an episode's actions (argmax and
// seeded sampling), the per-episode instruction encodings stack like a
// batched encoding, and the action choice rules.

#include "rollout/PolicyAgent.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>

#include "data/RxrTextFeatures.h"
#include "rollout/Evaluator.h"
#include "rollout/ObservationBatch.h"
#include "rollout/RolloutTestPolicy.h"
#include "rollout/RolloutTestWorld.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::rollout {
namespace {

using test::rolloutTestWorld;
using ::testing::HasSubstr;

std::vector<std::vector<int>> runActions(
    const test::TinyAgentModel& model,
    const std::vector<data::Episode>& episodes, int numEnvs, int threads,
    bool sample, uint64_t seed) {
  const auto& w = rolloutTestWorld();
  PolicyAgent agent(model.policy, model.encoder, numEnvs, sample, seed,
                    /*maxInstructionLength=*/200);
  VectorEnv envs(numEnvs, w.sim, w.task, std::make_shared<SceneCache>(w.sim),
                 threads);
  EvalConfig config;
  const EvaluationResult r =
      evaluateEpisodes(agent, envs, episodes, nullptr, config);
  std::vector<std::vector<int>> actions;
  for (const auto& e : r.episodes) actions.push_back(e.record.actions);
  return actions;
}

std::vector<data::Episode> firstEpisodes(size_t n) {
  const auto& w = rolloutTestWorld();
  return {w.episodes.begin(), w.episodes.begin() + static_cast<long>(n)};
}

// a behaviour worth comparing: long episodes with every move in them and
// episodes that change their action as they go (so the recurrent state and
// the observations matter)
void expectVaried(const std::vector<std::vector<int>>& actions) {
  std::set<int> kinds;
  size_t total = 0, mostKinds = 0;
  for (const auto& a : actions) {
    kinds.insert(a.begin(), a.end());
    total += a.size();
    mostKinds = std::max(mostKinds, std::set<int>(a.begin(), a.end()).size());
  }
  EXPECT_GE(kinds.size(), 3u);
  EXPECT_GE(mostKinds, 2u);
  EXPECT_GT(total, actions.size() * 10);
}

TEST(PolicyAgentTest, BatchingDoesNotChangeArgmaxActions) {
  // seeds whose random policies change actions within episodes (most
  // random argmax policies repeat one action)
  for (auto [type, seed] : {std::pair{models::PolicyType::kCma, 13},
                            std::pair{models::PolicyType::kSeq2Seq, 25}}) {
    SCOPED_TRACE(models::policyName(type));
    const auto model = test::tinyAgentModel(type, static_cast<uint64_t>(seed));
    const auto episodes = firstEpisodes(5);
    // one environment per run: each episode alone in its batch
    std::vector<std::vector<int>> alone;
    for (const auto& e : episodes)
      alone.push_back(runActions(model, {e}, 1, 1, false, 0).front());
    const auto batched =
        runActions(model, episodes, /*numEnvs=*/3, /*threads=*/2, false, 0);
    EXPECT_EQ(batched, alone);
    expectVaried(batched);
  }
}

TEST(PolicyAgentTest, SamplingIsReproducibleBySeedAndIndependentOfBatching) {
  const auto model =
      test::tinyAgentModel(models::PolicyType::kCma, 12, /*gain=*/30.0);
  const auto episodes = firstEpisodes(4);
  const auto a = runActions(model, episodes, 3, 2, true, /*seed=*/7);
  const auto b = runActions(model, episodes, 2, 1, true, /*seed=*/7);
  const auto c = runActions(model, episodes, 3, 2, true, /*seed=*/8);
  const auto argmax = runActions(model, episodes, 3, 2, false, 7);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  EXPECT_NE(a, argmax);
  expectVaried(a);
}

TEST(PolicyAgentTest, StackedInstructionsMatchABatchedEncoding) {
  for (auto type : {models::PolicyType::kCma, models::PolicyType::kSeq2Seq}) {
    SCOPED_TRACE(models::policyName(type));
    const auto model = test::tinyAgentModel(type, 13, 1.0, 0.0);
    model.policy->eval();
    torch::NoGradGuard noGrad;
    const auto episodes = firstEpisodes(3);
    std::vector<const data::Episode*> all;
    for (const auto& e : episodes) all.push_back(&e);
    const auto batched =
        model.policy->encodeInstruction(batchInstructions(all, 200));
    std::vector<models::EncodedInstruction> rows;
    for (const auto* e : all) {
      const data::Episode* one[] = {e};
      rows.push_back(
          model.policy->encodeInstruction(batchInstructions(one, 200)));
    }
    std::vector<const models::EncodedInstruction*> pointers;
    for (const auto& r : rows) pointers.push_back(&r);
    const auto stacked = stackInstructions(pointers);

    // one policy step on random features: identical outputs
    const models::ModelConfig& c = model.policy->config();
    const auto rs = models::rgbFeatureShape(c);
    const auto ds = models::depthFeatureShape(c);
    models::PolicyInputs in;
    in.rgb = torch::rand({3, rs[0], rs[1], rs[2]});
    in.depth = torch::rand({3, ds[0], ds[1], ds[2]});
    in.prev_actions = torch::tensor({0, 2, 1}, torch::kInt64);
    in.not_done = torch::tensor({0.0f, 1.0f, 1.0f});
    const torch::Tensor hidden =
        torch::randn({3, c.recurrentStateRows(), c.hidden_size});
    const auto x = model.policy->step(batched, in, hidden);
    const auto y = model.policy->step(stacked, in, hidden);
    EXPECT_TRUE(torch::allclose(x.logits, y.logits, 1e-5, 1e-6));
    EXPECT_TRUE(torch::allclose(x.hidden, y.hidden, 1e-5, 1e-6));
    if (type == models::PolicyType::kCma) {
      EXPECT_EQ(stacked.mask.sizes(), batched.mask.sizes());
      EXPECT_TRUE(torch::equal(stacked.mask, batched.mask));
    }
  }
}

TEST(PolicyAgentTest, ChoiceRules) {
  std::mt19937_64 rng(1);
  // argmax takes the first maximum and draws nothing
  const std::vector<double> tie = {0.5, 2.0, 2.0, -1.0};
  const auto before = rng;
  EXPECT_EQ(chooseAction(tie, false, rng), 1);
  EXPECT_EQ(rng, before);
  // sampling never picks a zero-mass action and follows the masses
  std::vector<int> counts(4, 0);
  const std::vector<double> masses = {0.0, 0.25, 0.75, 0.0};
  for (int i = 0; i < 4000; ++i)
    ++counts[static_cast<size_t>(sampleIndex(masses, rng))];
  EXPECT_EQ(counts[0], 0);
  EXPECT_EQ(counts[3], 0);
  EXPECT_NEAR(counts[2] / 4000.0, 0.75, 0.03);  // > 4 sigma
  // a logit far below the others is (practically) never sampled
  const std::vector<double> logits = {-50.0, 0.0, 0.0, 0.0};
  for (int i = 0; i < 1000; ++i) EXPECT_NE(chooseAction(logits, true, rng), 0);
  // the same generator state gives the same draw
  std::mt19937_64 g1(5), g2(5);
  for (int i = 0; i < 20; ++i)
    EXPECT_EQ(chooseAction(tie, true, g1), chooseAction(tie, true, g2));
  EXPECT_THROW(sampleIndex(std::vector<double>{0.0, 0.0}, rng),
               std::invalid_argument);
  EXPECT_THROW(sampleIndex(std::vector<double>{-1.0, 2.0}, rng),
               std::invalid_argument);
}

TEST(PolicyAgentTest, MisuseIsReported) {
  const auto model = test::tinyAgentModel(models::PolicyType::kCma, 14);
  PolicyAgent agent(model.policy, model.encoder, 2, false, 0, 200);
  const auto& w = rolloutTestWorld();
  VectorEnv envs(2, w.sim, w.task, std::make_shared<SceneCache>(w.sim), 1);
  const std::vector<int> active = {1};
  EXPECT_THAT(
      [&] { agent.act(envs, active); },
      ::testing::Throws<std::invalid_argument>(::testing::Property(
          &std::exception::what, HasSubstr("environment 1 was never reset"))));
  EXPECT_THAT([&] { agent.reset(2, w.episodes[0]); },
              ::testing::Throws<std::invalid_argument>(::testing::Property(
                  &std::exception::what,
                  HasSubstr("environment 2 out of range [0, 2)"))));
  models::ModelConfig noDepth = test::tinyModel(models::PolicyType::kCma);
  noDepth.no_depth = true;
  EXPECT_THAT(
      [&] {
        PolicyAgent bad(model.policy, models::ObservationEncoder(noDepth), 1,
                        false, 0, 200);
      },
      ::testing::Throws<std::invalid_argument>(::testing::Property(
          &std::exception::what, HasSubstr("encoder's modalities"))));
}

}  // namespace
}  // namespace vln::rollout

namespace vln::rollout {
namespace {

// the agent's attention after every step of every episode, by input position
class AttentionRecorder : public EpisodeObserver {
 public:
  explicit AttentionRecorder(const Agent& agent) : agent_(agent) {}
  bool wantsFrames(int) const override { return false; }
  void episodeStarted(int, VectorEnv&, int) override {}
  void episodeStepped(int index, VectorEnv&, int env, sim::Action) override {
    rows[index].push_back(agent_.instructionAttention(env));
  }
  void episodeFinished(int, VectorEnv&, int, const EpisodeResult&,
                       bool) override {}
  std::map<int, std::vector<std::vector<float>>> rows;

 private:
  const Agent& agent_;
};

std::map<int, std::vector<std::vector<float>>> attentionOf(
    const test::TinyAgentModel& model,
    const std::vector<data::Episode>& episodes, int numEnvs, bool keep) {
  const auto& w = rolloutTestWorld();
  PolicyAgent agent(model.policy, model.encoder, numEnvs, false, 0, 200);
  agent.keepInstructionAttention(keep);
  VectorEnv envs(numEnvs, w.sim, w.task, std::make_shared<SceneCache>(w.sim),
                 2);
  AttentionRecorder recorder(agent);
  evaluateEpisodes(agent, envs, episodes, nullptr, EvalConfig{}, {}, &recorder);
  return recorder.rows;
}

TEST(PolicyAgentTest, CmaAttentionOverTheInstructionPerEnvironment) {
  const auto cma = test::tinyAgentModel(models::PolicyType::kCma, 13);
  const auto episodes = firstEpisodes(4);
  const auto batched = attentionOf(cma, episodes, /*numEnvs=*/3, /*keep=*/true);
  ASSERT_EQ(batched.size(), episodes.size());
  for (const auto& [index, rows] : batched) {
    const int words = data::unpaddedLength(
        episodes[static_cast<size_t>(index)].instruction.instruction_tokens);
    for (const auto& row : rows) {
      // one weight per token the policy read, a distribution over them
      ASSERT_EQ(row.size(), static_cast<size_t>(words));
      double sum = 0.0;
      for (float w : row) {
        EXPECT_GE(w, 0.0f);
        sum += w;
      }
      EXPECT_NEAR(sum, 1.0, 1e-5);
    }
  }
  // the same rows whatever shares the batch
  const auto alone = attentionOf(cma, {episodes[2]}, 1, true);
  const auto& a = alone.at(0);
  const auto& b = batched.at(2);
  ASSERT_EQ(a.size(), b.size());
  for (size_t s = 0; s < a.size(); ++s)
    for (size_t k = 0; k < a[s].size(); ++k)
      EXPECT_NEAR(a[s][k], b[s][k], 1e-5);
  // not asked for, or a policy without attention: none
  for (const auto& [index, rows] : attentionOf(cma, episodes, 3, false))
    for (const auto& row : rows) EXPECT_TRUE(row.empty());
  const auto seq2seq = test::tinyAgentModel(models::PolicyType::kSeq2Seq, 25);
  for (const auto& [index, rows] : attentionOf(seq2seq, episodes, 3, true))
    for (const auto& row : rows) EXPECT_TRUE(row.empty());
}

}  // namespace
}  // namespace vln::rollout

// ---------------------------------------------------------------------------
// RxR policies: six actions (LOOK_UP / LOOK_DOWN) and text-feature
// instructions from a feature source

namespace vln::rollout {
namespace {

// deterministic per-episode text features [3 + id % 5, 8]
torch::Tensor syntheticFeatures(const data::Episode& episode) {
  torch::Generator gen = at::detail::createCPUGenerator(
      static_cast<uint64_t>(episode.episode_id) + 1);
  return torch::randn({3 + episode.episode_id % 5, 8}, gen);
}

test::TinyAgentModel rxrAgentModel(models::PolicyType type, uint64_t seed) {
  torch::manual_seed(seed);
  test::TinyAgentModel m;
  models::ModelConfig c = models::test::tinyRxrConfig(type);
  c.vocab_size = test::kTestVocab;
  m.policy = models::makePolicy(c);
  m.encoder = models::ObservationEncoder(c);
  torch::NoGradGuard noGrad;
  for (auto& p : m.policy->named_parameters()) {
    if (p.key() == "action_head.weight") p.value().mul_(400.0);
    if (p.key() == "action_head.bias") p.value()[0].sub_(3.0);
  }
  return m;
}

std::vector<EpisodeResult> runRxr(const test::TinyAgentModel& model,
                                  const std::vector<data::Episode>& episodes,
                                  int numEnvs) {
  const auto& w = rolloutTestWorld();
  sim::SimConfig simConfig = w.sim;
  simConfig.agent.look_actions = true;
  PolicyAgent agent(model.policy, model.encoder, numEnvs, false, 0, 512);
  agent.setInstructionFeatures(syntheticFeatures);
  VectorEnv envs(numEnvs, simConfig, w.task,
                 std::make_shared<SceneCache>(simConfig), 2);
  return evaluateEpisodes(agent, envs, episodes, nullptr, EvalConfig{})
      .episodes;
}

TEST(PolicyAgentTest, SixActionPolicyLooksUpAndDown) {
  auto model = rxrAgentModel(models::PolicyType::kCma, 13);
  {
    // only LOOK_UP (4) can win: the camera pitches, the agent stays put
    torch::NoGradGuard noGrad;
    model.policy->named_parameters()["action_head.weight"].zero_();
    model.policy->named_parameters()["action_head.bias"].copy_(
        torch::tensor({-9.0f, -9.0f, -9.0f, -9.0f, 9.0f, -9.0f}));
  }
  const auto results = runRxr(model, firstEpisodes(1), 1);
  ASSERT_EQ(results.size(), 1u);
  const auto& record = results[0].record;
  ASSERT_FALSE(record.actions.empty());
  for (int a : record.actions) EXPECT_EQ(a, 4);
  ASSERT_FALSE(record.pitches.empty());
  EXPECT_NE(record.pitches.back(), 0.0f);
  {
    torch::NoGradGuard noGrad;
    model.policy->named_parameters()["action_head.bias"].copy_(
        torch::tensor({-9.0f, -9.0f, -9.0f, -9.0f, -9.0f, 9.0f}));
  }
  const auto down = runRxr(model, firstEpisodes(1), 1);
  ASSERT_EQ(down.size(), 1u);
  ASSERT_FALSE(down[0].record.actions.empty());
  for (int a : down[0].record.actions) EXPECT_EQ(a, 5);
}

TEST(PolicyAgentTest, TextFeaturePolicyIsIndependentOfBatching) {
  for (auto type : {models::PolicyType::kCma, models::PolicyType::kSeq2Seq}) {
    SCOPED_TRACE(models::policyName(type));
    const auto model = rxrAgentModel(type, 21);
    const auto episodes = firstEpisodes(4);
    std::vector<std::vector<int>> alone, batched;
    for (const auto& e : episodes)
      alone.push_back(runRxr(model, {e}, 1)[0].record.actions);
    for (const auto& r : runRxr(model, episodes, 3))
      batched.push_back(r.record.actions);
    EXPECT_EQ(batched, alone);
    std::set<int> kinds;
    for (const auto& a : batched) kinds.insert(a.begin(), a.end());
    EXPECT_GE(kinds.size(), 2u);
  }
}

TEST(PolicyAgentTest, TextFeaturePolicyNeedsASource) {
  const auto model = rxrAgentModel(models::PolicyType::kCma, 3);
  PolicyAgent agent(model.policy, model.encoder, 1, false, 0, 512);
  EXPECT_THAT(
      [&] { agent.reset(0, rolloutTestWorld().episodes[0]); },
      ::testing::Throws<std::invalid_argument>(::testing::Property(
          &std::exception::what,
          HasSubstr("model.instruction_features is rxr_text but no text "
                    "feature source"))));
}

TEST(PolicyAgentTest, RxrTextFeatureFilesFeedThePolicy) {
  // a features file in RxR's layout, read by rxrTextFeatureSource
  vln::test::TempDir dir;
  data::Episode episode = rolloutTestWorld().episodes[0];
  episode.instruction.instruction_id = 42;
  episode.instruction.language = "en-IN";
  const torch::Tensor rows = torch::randn({5, 8});
  std::vector<float> values(rows.data_ptr<float>(),
                            rows.data_ptr<float>() + rows.numel());
  const std::filesystem::path file =
      data::rxrTextFeaturesPath(dir.path(), "val_seen", 42, "en-IN");
  std::filesystem::create_directories(file.parent_path());
  data::writeRxrTextFeatures(file, values, 8);
  const InstructionFeatureSource source =
      rxrTextFeatureSource(dir.path(), "val_seen", 8);
  // the file's rows only, not RxR's 512-row block
  EXPECT_TRUE(torch::equal(source(episode), rows));
  EXPECT_EQ(instructionFeatures(source, episode, 8, 3).sizes(),
            (std::vector<int64_t>{1, 3, 8}));
  EXPECT_THAT(vln::test::errorOf([&] {
                rxrTextFeatureSource(dir.path(), "val_seen", 16)(episode);
              }),
              HasSubstr("must be [tokens, 16]"));
  data::Episode noId = episode;
  noId.instruction.instruction_id.reset();
  EXPECT_THAT(vln::test::errorOf([&] { source(noId); }),
              HasSubstr("has no instruction.instruction_id"));
  // padded rows stack with zeros after each
  const torch::Tensor a = torch::ones({1, 2, 8}), b = torch::ones({1, 4, 8});
  const torch::Tensor stacked = batchInstructionFeatures({{a, b}});
  EXPECT_EQ(stacked.sizes(), (std::vector<int64_t>{2, 4, 8}));
  EXPECT_EQ(stacked[0].slice(0, 2).abs().sum().item<float>(), 0.0f);
}

}  // namespace
}  // namespace vln::rollout
