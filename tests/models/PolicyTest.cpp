// Properties shared by both policies (Policy.cpp, Seq2SeqPolicy.cpp,
// CmaPolicy.cpp): shapes, step mode == sequence mode, PAD invariance,
// ablations, gradients, save/load.
#include "models/Policy.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "ModelTestUtil.h"
#include "models/Loss.h"
#include "models/StateDict.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::models {
namespace {

using test::randomInputs;
using test::randomTokens;
using test::stepOf;
using test::tinyConfig;
using ::testing::HasSubstr;

// Seq2Seq, CMA, and CMA with the turn count (a third recurrent row)
struct PolicyVariant {
  PolicyType policy;
  bool countsTurns;
};

class PolicyTest : public ::testing::TestWithParam<PolicyVariant> {
 protected:
  void SetUp() override { torch::manual_seed(7); }
  ModelConfig withVariant(ModelConfig c) const {
    if (GetParam().countsTurns) c.turn_count_embedding_dim = 8;
    return c;
  }
  ModelConfig config() const {
    return withVariant(tinyConfig(GetParam().policy));
  }
  ModelConfig rxrConfig() const {
    return withVariant(test::tinyRxrConfig(GetParam().policy));
  }
};

TEST_P(PolicyTest, SequenceOutputsHaveDocumentedShapes) {
  const ModelConfig c = config();
  auto policy = makePolicy(c);
  const auto instr = policy->encodeInstruction(randomTokens({4, 7, 2}, 9, 23));
  const auto out = policy->forwardSequence(instr, randomInputs(c, 5, 3),
                                           policy->initialHidden(3));
  EXPECT_EQ(out.logits.sizes(), (std::vector<int64_t>{5, 3, kNumActions}));
  EXPECT_EQ(out.progress.sizes(), (std::vector<int64_t>{5, 3}));
  EXPECT_EQ(out.hidden.sizes(),
            (std::vector<int64_t>{3, c.recurrentStateRows(), c.hidden_size}));
  EXPECT_TRUE(out.logits.isfinite().all().item<bool>());
  EXPECT_TRUE((out.progress.abs() < 1).all().item<bool>());
}

TEST_P(PolicyTest, WithoutProgressMonitorProgressIsUndefined) {
  ModelConfig c = config();
  c.progress_monitor = false;
  auto policy = makePolicy(c);
  const auto instr = policy->encodeInstruction(randomTokens({3}, 3, 23));
  const auto out = policy->forwardSequence(instr, randomInputs(c, 2, 1),
                                           policy->initialHidden(1));
  EXPECT_FALSE(out.progress.defined());
}

TEST_P(PolicyTest, StepModeEqualsSequenceModeWithResetsMidBatch) {
  const ModelConfig c = config();
  auto policy = makePolicy(c);
  policy->eval();
  const int64_t steps = 7, batch = 3;
  // row 1 starts a new episode at t = 3, row 2 at t = 5
  const PolicyInputs in = randomInputs(c, steps, batch, {{3, 1}, {5, 2}});
  const torch::Tensor tokens = randomTokens({5, 3, 8}, 8, 23);
  // a non-zero initial state makes the t = 0 reset observable
  const torch::Tensor h0 =
      torch::randn({batch, c.recurrentStateRows(), c.hidden_size});

  const auto instr = policy->encodeInstruction(tokens);
  const auto seq = policy->forwardSequence(instr, in, h0);
  torch::Tensor h = h0;
  for (int64_t t = 0; t < steps; ++t) {
    const auto out = policy->step(instr, stepOf(in, t), h);
    EXPECT_TRUE(torch::allclose(out.logits, seq.logits[t], 1e-5, 1e-6))
        << "t=" << t;
    EXPECT_TRUE(torch::allclose(out.progress, seq.progress[t], 1e-5, 1e-6))
        << "t=" << t;
    h = out.hidden;
  }
  EXPECT_TRUE(torch::allclose(h, seq.hidden, 1e-5, 1e-6));
}

TEST_P(PolicyTest, ResetMakesRowIndependentOfItsPast) {
  const ModelConfig c = config();
  auto policy = makePolicy(c);
  const auto instr = policy->encodeInstruction(randomTokens({4, 6}, 6, 23));
  PolicyInputs a = randomInputs(c, 6, 2, {{3, 0}});
  PolicyInputs b = a;
  b.rgb = a.rgb.clone();
  b.depth = a.depth.clone();
  b.prev_actions = a.prev_actions.clone();
  // change row 0 before its reset at t = 3, and its pre-reset action
  b.rgb.slice(0, 0, 3).select(1, 0).uniform_();
  b.depth.slice(0, 0, 3).select(1, 0).uniform_();
  b.prev_actions[3][0] = (a.prev_actions[3][0].item<int64_t>() + 1) % 4;
  const auto outA = policy->forwardSequence(instr, a, policy->initialHidden(2));
  const auto outB = policy->forwardSequence(instr, b, policy->initialHidden(2));
  const torch::Tensor after = outA.logits.slice(0, 3).select(1, 0);
  EXPECT_TRUE(torch::allclose(after, outB.logits.slice(0, 3).select(1, 0)));
  EXPECT_FALSE(torch::allclose(outA.logits.slice(0, 0, 3).select(1, 0),
                               outB.logits.slice(0, 0, 3).select(1, 0)));
}

TEST_P(PolicyTest, ExtraPaddingNeverChangesOutputs) {
  const ModelConfig c = config();
  auto policy = makePolicy(c);
  const torch::Tensor tokens = randomTokens({3, 6, 1}, 6, 23);
  const torch::Tensor padded =
      torch::cat({tokens, torch::zeros({3, 11}, torch::kInt64)}, 1);
  const PolicyInputs in = randomInputs(c, 4, 3);
  const auto a = policy->forwardSequence(policy->encodeInstruction(tokens), in,
                                         policy->initialHidden(3));
  const auto b = policy->forwardSequence(policy->encodeInstruction(padded), in,
                                         policy->initialHidden(3));
  EXPECT_TRUE(torch::allclose(a.logits, b.logits, 1e-6, 1e-7));
  EXPECT_TRUE(torch::allclose(a.hidden, b.hidden, 1e-6, 1e-7));
}

TEST_P(PolicyTest, OutputsDependOnEveryUsedInput) {
  // guards the ablation tests below against passing vacuously
  const ModelConfig c = config();
  auto policy = makePolicy(c);
  const torch::Tensor tokens = randomTokens({5, 5}, 5, 23);
  const PolicyInputs in = randomInputs(c, 3, 2);
  const auto base = policy->forwardSequence(policy->encodeInstruction(tokens),
                                            in, policy->initialHidden(2));
  PolicyInputs rgb = in, depth = in;
  rgb.rgb = torch::rand_like(in.rgb);
  depth.depth = torch::rand_like(in.depth);
  auto differs = [&](const torch::Tensor& tok, const PolicyInputs& x) {
    const auto out = policy->forwardSequence(policy->encodeInstruction(tok), x,
                                             policy->initialHidden(2));
    return !torch::allclose(out.logits, base.logits, 1e-6, 1e-8);
  };
  EXPECT_TRUE(differs(tokens, rgb));
  EXPECT_TRUE(differs(tokens, depth));
  EXPECT_TRUE(differs(randomTokens({5, 5}, 5, 23), in));
}

TEST_P(PolicyTest, AblatedInputsDoNotInfluenceOutputs) {
  for (int which = 0; which < 3; ++which) {
    ModelConfig c = config();
    c.no_rgb = which == 0;
    c.no_depth = which == 1;
    c.no_instruction = which == 2;
    auto policy = makePolicy(c);
    const torch::Tensor tokens = randomTokens({5, 5}, 5, 23);
    const PolicyInputs in = randomInputs(c, 3, 2);
    const auto base = policy->forwardSequence(policy->encodeInstruction(tokens),
                                              in, policy->initialHidden(2));
    PolicyInputs perturbed = in;
    torch::Tensor otherTokens = tokens;
    if (c.no_rgb) perturbed.rgb = torch::rand_like(in.rgb) * 10;
    if (c.no_depth) perturbed.depth = torch::rand_like(in.depth) * 10;
    if (c.no_instruction) otherTokens = randomTokens({2, 7}, 7, 23);
    const auto out =
        policy->forwardSequence(policy->encodeInstruction(otherTokens),
                                perturbed, policy->initialHidden(2));
    EXPECT_TRUE(torch::equal(out.logits, base.logits)) << "ablation " << which;
    // removed, not zeroed: nothing of that branch is left in the network
    for (const auto& [name, tensor] : namedState(*policy)) {
      if (c.no_rgb) {
        EXPECT_EQ(name.find("rgb"), std::string::npos) << name;
      }
      if (c.no_depth) {
        EXPECT_EQ(name.find("depth"), std::string::npos) << name;
      }
      if (c.no_instruction) {
        EXPECT_EQ(name.find("instruction"), std::string::npos) << name;
      }
    }
  }
}

TEST_P(PolicyTest, NoVisionModelStillRuns) {
  ModelConfig c = config();
  c.no_rgb = c.no_depth = true;
  auto policy = makePolicy(c);
  PolicyInputs in = randomInputs(c, 3, 2);
  in.rgb = torch::Tensor();
  in.depth = torch::Tensor();
  const auto out = policy->forwardSequence(
      policy->encodeInstruction(randomTokens({2, 4}, 4, 23)), in,
      policy->initialHidden(2));
  EXPECT_EQ(out.logits.sizes(), (std::vector<int64_t>{3, 2, kNumActions}));
}

TEST_P(PolicyTest, GradientsMatchFiniteDifferences) {
  ModelConfig c = config();
  c.fine_tune_embeddings = true;
  auto policy = makePolicy(c);
  policy->to(torch::kDouble);
  const torch::Tensor tokens = randomTokens({4, 3}, 4, 23);
  const PolicyInputs in = randomInputs(c, 4, 2, {{2, 1}}, torch::kDouble);
  const torch::Tensor h0 =
      torch::randn({2, c.recurrentStateRows(), c.hidden_size}, torch::kDouble);
  const torch::Tensor probe = torch::randn({4, 2, kNumActions}, torch::kDouble);
  const torch::Tensor probeP = torch::randn({4, 2}, torch::kDouble);
  auto loss = [&] {
    const auto out =
        policy->forwardSequence(policy->encodeInstruction(tokens), in, h0);
    return (out.logits * probe).sum() + (out.progress * probeP).sum();
  };
  policy->zero_grad();
  loss().backward();

  int checked = 0;
  for (auto& item : policy->named_parameters()) {
    torch::Tensor p = item.value();
    if (!p.requires_grad()) continue;
    ASSERT_TRUE(p.grad().defined()) << item.key();
    // two entries per tensor, at fixed pseudo-random positions
    for (int64_t k : {int64_t{0}, p.numel() / 2 + 1}) {
      if (k >= p.numel()) continue;
      torch::Tensor flat = p.view(-1);
      const double eps = 1e-6;
      const double orig = flat[k].item<double>();
      double plus, minus;
      {
        torch::NoGradGuard g;
        flat[k] = orig + eps;
        plus = loss().item<double>();
        flat[k] = orig - eps;
        minus = loss().item<double>();
        flat[k] = orig;
      }
      const double numeric = (plus - minus) / (2 * eps);
      const double analytic = p.grad().view(-1)[k].item<double>();
      EXPECT_NEAR(analytic, numeric, 1e-6 + 1e-5 * std::abs(numeric))
          << item.key() << "[" << k << "]";
      ++checked;
    }
  }
  EXPECT_GT(checked, 20);
}

TEST_P(PolicyTest, SaveLoadRoundTripReproducesOutputs) {
  const ModelConfig c = config();
  auto a = makePolicy(c);
  torch::manual_seed(99);
  auto b = makePolicy(c);
  const torch::Tensor tokens = randomTokens({4, 2}, 4, 23);
  const PolicyInputs in = randomInputs(c, 3, 2);
  auto run = [&](PolicyImpl& p) {
    return p
        .forwardSequence(p.encodeInstruction(tokens), in, p.initialHidden(2))
        .logits;
  };
  ASSERT_FALSE(torch::allclose(run(*a), run(*b)));
  vln::test::TempDir dir;
  saveModule(*a, dir / "policy.pt");
  loadModule(*b, dir / "policy.pt");
  EXPECT_TRUE(torch::equal(run(*a), run(*b)));
}

TEST_P(PolicyTest, DropoutActsOnlyWhileTraining) {
  ModelConfig c = config();
  c.dropout = 0.5;
  auto policy = makePolicy(c);
  c.dropout = 0.0;
  auto plain = makePolicy(c);
  {
    torch::NoGradGuard noGrad;
    auto target = plain->named_parameters();
    for (const auto& p : policy->named_parameters())
      target[p.key()].copy_(p.value());
  }
  const torch::Tensor tokens = randomTokens({4, 7, 2}, 9, 23);
  const PolicyInputs in = randomInputs(c, 5, 3);
  auto run = [&](PolicyImpl& p) {
    return p
        .forwardSequence(p.encodeInstruction(tokens), in, p.initialHidden(3))
        .logits;
  };
  // acting (collection, evaluation) sees the weights without dropout
  policy->eval();
  const torch::Tensor acting = run(*policy);
  plain->train();
  EXPECT_TRUE(torch::equal(acting, run(*plain)));
  // training draws masks from the default generator, which checkpoints
  // save: the same seed gives the same masks (bit-exact resume)
  policy->train();
  torch::manual_seed(3);
  const torch::Tensor first = run(*policy);
  const torch::Tensor second = run(*policy);
  torch::manual_seed(3);
  EXPECT_TRUE(torch::equal(first, run(*policy)));
  EXPECT_FALSE(torch::allclose(first, second));
  EXPECT_FALSE(torch::allclose(first, acting));
}

TEST_P(PolicyTest, FrozenEmbeddingsGetNoGradient) {
  ModelConfig c = config();
  const torch::Tensor glove = torch::randn({c.vocab_size, c.embedding_dim});
  auto policy = makePolicy(c, glove);
  const auto& emb = policy->instruction_encoder->embedding->weight;
  EXPECT_TRUE(torch::equal(emb, glove));
  EXPECT_FALSE(emb.requires_grad());
  c.fine_tune_embeddings = true;
  EXPECT_TRUE(
      makePolicy(c)->instruction_encoder->embedding->weight.requires_grad());
}

TEST_P(PolicyTest, BadShapesAreNamed) {
  const ModelConfig c = config();
  auto policy = makePolicy(c);
  const auto instr = policy->encodeInstruction(randomTokens({2}, 2, 23));
  PolicyInputs in = randomInputs(c, 2, 1);
  in.rgb = torch::rand({2, 1, 3, 4, 4});
  try {
    policy->forwardSequence(instr, in, policy->initialHidden(1));
    FAIL() << "expected a shape error";
  } catch (const c10::Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("expected rgb features [2, 1, 64, 4, 4]"));
  }
  EXPECT_THROW(makePolicy(c, torch::zeros({3, 3})), std::invalid_argument);
}

// ---------------------------------------------------------------------------
// RxR: six actions and text-feature instructions (model.num_actions,
// model.instruction_features: rxr_text)

TEST_P(PolicyTest, SixActionsWidenHeadAndPreviousActionEmbedding) {
  ModelConfig c = config();
  c.seq2seq_prev_action = true;
  const ModelConfig four = c;
  c.num_actions = static_cast<int>(kNumLookActions);
  auto policy = makePolicy(c);
  const auto instr = policy->encodeInstruction(randomTokens({4, 2}, 4, 23));
  PolicyInputs in = randomInputs(c, 3, 2);
  in.prev_actions.fill_(5);  // LOOK_DOWN: the embedding's last entry
  const auto out = policy->forwardSequence(instr, in, policy->initialHidden(2));
  EXPECT_EQ(out.logits.sizes(), (std::vector<int64_t>{3, 2, 6}));
  EXPECT_TRUE(out.logits.isfinite().all().item<bool>());
  const auto state = namedState(*policy);
  auto shapeOf = [&](const std::string& name) {
    for (const auto& [key, tensor] : state)
      if (key == name) return tensor.sizes().vec();
    ADD_FAILURE() << "no tensor " << name;
    return std::vector<int64_t>{};
  };
  // the start entry, then one per action
  EXPECT_EQ(shapeOf("prev_action_embedding.weight"),
            (std::vector<int64_t>{7, c.prev_action_embedding_dim}));
  EXPECT_EQ(shapeOf("action_head.weight"),
            (std::vector<int64_t>{6, c.hidden_size}));
  EXPECT_EQ(shapeOf("action_head.bias"), (std::vector<int64_t>{6}));
  // the same tensor names as the four-action model: only shapes differ
  std::vector<std::string> names, fourNames;
  for (const auto& item : state) names.push_back(item.first);
  for (const auto& item : namedState(*makePolicy(four)))
    fourNames.push_back(item.first);
  EXPECT_EQ(names, fourNames);
}

TEST_P(PolicyTest, TextFeaturePaddingNeverChangesOutputs) {
  const ModelConfig c = rxrConfig();
  auto policy = makePolicy(c);
  policy->eval();
  EXPECT_TRUE(policy->instruction_encoder->embedding.is_empty());
  const torch::Tensor features = test::randomTextFeatures({3, 6, 1}, 6, 8);
  // RxR pads every instruction to 512 rows
  const torch::Tensor padded =
      torch::cat({features, torch::zeros({3, 506, 8})}, 1);
  const PolicyInputs in = randomInputs(c, 4, 3);
  const EncodedInstruction a = policy->encodeInstruction(features);
  const EncodedInstruction b = policy->encodeInstruction(padded);
  if (GetParam().policy == PolicyType::kCma) {
    // the mask covers the real rows; the padded encoding is trimmed
    EXPECT_TRUE(torch::equal(a.mask.sum(1).to(torch::kInt64),
                             torch::tensor({3, 6, 1}, torch::kInt64)));
    EXPECT_EQ(b.mask.size(1), 6);
  }
  const auto outA = policy->forwardSequence(a, in, policy->initialHidden(3));
  const auto outB = policy->forwardSequence(b, in, policy->initialHidden(3));
  EXPECT_TRUE(torch::allclose(outA.logits, outB.logits, 1e-6, 1e-7));
  EXPECT_TRUE(torch::allclose(outA.hidden, outB.hidden, 1e-6, 1e-7));

  // a row alone gives what it gives beside others (packed by length)
  const auto alone = policy->forwardSequence(
      policy->encodeInstruction(features.slice(0, 2)),
      {in.rgb.slice(1, 2), in.depth.slice(1, 2), in.prev_actions.slice(1, 2),
       in.not_done.slice(1, 2)},
      policy->initialHidden(1));
  EXPECT_TRUE(torch::allclose(alone.logits.select(1, 0),
                              outA.logits.select(1, 2), 1e-5, 1e-6));

  // what padding hides does matter where it is real
  torch::Tensor changed = features.clone();
  changed[2][0] += 1.0;
  const auto outC = policy->forwardSequence(policy->encodeInstruction(changed),
                                            in, policy->initialHidden(3));
  EXPECT_FALSE(torch::allclose(outA.logits.select(1, 2),
                               outC.logits.select(1, 2), 1e-6, 1e-8));
}

TEST_P(PolicyTest, TextFeatureTrainingLowersTheLoss) {
  // a few Adam steps teacher-forced on synthetic RxR-like episodes (text
  // features, all six actions as labels)
  const ModelConfig c = rxrConfig();
  auto policy = makePolicy(c);
  const int64_t steps = 6, batch = 4;
  const torch::Tensor features = test::randomTextFeatures({5, 9, 3, 7}, 9, 8);
  const PolicyInputs in = randomInputs(c, steps, batch);
  // episode b's action at step t is (t + 2b) mod 6: every action occurs,
  // and which one depends on the episode
  const torch::Tensor actions =
      (torch::arange(steps).unsqueeze(1) + 2 * torch::arange(batch)) %
      c.num_actions;
  const torch::Tensor valid = torch::ones({steps, batch}, torch::kBool);
  const torch::Tensor weights = inflectionWeights(actions, valid, 1.0);
  torch::optim::Adam adam(policy->parameters(),
                          torch::optim::AdamOptions(0.01));
  auto loss = [&] {
    const auto out = policy->forwardSequence(
        policy->encodeInstruction(features), in, policy->initialHidden(batch));
    return weightedActionLoss(out.logits, actions, weights);
  };
  const double before = loss().item<double>();
  for (int i = 0; i < 40; ++i) {
    adam.zero_grad();
    loss().backward();
    adam.step();
  }
  const double after = loss().item<double>();
  EXPECT_LT(after, 0.5 * before) << "before " << before << " after " << after;
  // the instruction LSTM learns too
  EXPECT_TRUE(policy->instruction_encoder->lstm->parameters()[0]
                  .grad()
                  .abs()
                  .sum()
                  .item<double>() > 0.0);
}

TEST_P(PolicyTest, TextFeatureModelRefusesTokensAndGlove) {
  const ModelConfig c = rxrConfig();
  auto policy = makePolicy(c);
  try {
    policy->encodeInstruction(randomTokens({3}, 3, 23));
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("model.instruction_features is rxr_text"));
  }
  EXPECT_THAT(vln::test::errorOf([&] {
                policy->encodeInstruction(torch::zeros({2, 4, 8}));
              }),
              HasSubstr("all zero"));
  EXPECT_THAT(vln::test::errorOf([&] {
                policy->encodeInstruction(torch::ones({2, 4, 9}));
              }),
              HasSubstr("model.text_feature_dim"));
  EXPECT_THAT(vln::test::errorOf([&] {
                makePolicy(c, torch::zeros({c.vocab_size, c.embedding_dim}));
              }),
              HasSubstr("no word embedding"));
}

INSTANTIATE_TEST_SUITE_P(
    BothPolicies, PolicyTest,
    ::testing::Values(PolicyVariant{PolicyType::kSeq2Seq, false},
                      PolicyVariant{PolicyType::kCma, false},
                      PolicyVariant{PolicyType::kCma, true}),
    [](const auto& info) {
      return std::string(policyName(info.param.policy)) +
             (info.param.countsTurns ? "_turn_count" : "");
    });

// The R2R models (model.num_actions 4, token instructions) give the outputs
// they gave before num_actions and instruction_features existed (first
// printed at 7cb4972 on a machine with AVX-512); values printed by this
// test's body with the kernels pinned to AVX2 (support/TestMain.cpp) on
// 2026-11-27, which is what CI's machines without AVX-512 compute.
TEST(PolicyGoldenTest, R2rOutputsUnchangedAtFixedSeed) {
  struct Golden {
    PolicyType policy;
    bool prevAction;
    std::vector<float> logits;    // [3, 2, 4] flattened
    std::vector<float> progress;  // [3, 2] flattened
    double hiddenSum;
  };
  const std::vector<Golden> goldens = {
      {PolicyType::kSeq2Seq,
       /*prevAction=*/false,
       {-5.233333795e-04f, 3.639626957e-04f,  1.070608734e-03f,
        4.231448402e-04f,  1.840883197e-04f,  1.375789987e-03f,
        1.394670922e-03f,  2.102541039e-04f,  -8.372360608e-04f,
        3.947739606e-04f,  1.196097117e-03f,  3.904789628e-04f,
        7.921442011e-05f,  2.240037546e-03f,  1.998670865e-03f,
        8.046799921e-04f,  -7.731194491e-04f, 2.119960991e-04f,
        1.636772067e-03f,  6.527336664e-04f,  -7.267043111e-04f,
        1.671644626e-03f,  1.908235950e-03f,  -7.805086352e-05f},
       {-1.571560949e-01f, -2.889722399e-02f, -2.433652282e-01f,
        -5.094786361e-02f, -2.840750813e-01f, -1.188256964e-01f},
       -1.419512272e+00},
      {PolicyType::kSeq2Seq,
       /*prevAction=*/true,
       {6.892103120e-04f,  7.058540941e-04f,  -1.945937518e-03f,
        -5.470326287e-04f, 5.492358468e-04f,  8.396396297e-04f,
        -2.861871617e-03f, 1.138942316e-04f,  -1.667243778e-03f,
        -3.472384298e-03f, -1.956142718e-03f, -7.707132027e-04f,
        1.276213676e-03f,  -3.676088818e-04f, -2.230267040e-03f,
        -3.462505527e-03f, 2.085891319e-04f,  -1.819767524e-03f,
        -1.826891908e-03f, -3.192408010e-03f, 5.898732343e-04f,
        1.135579194e-03f,  -2.751978114e-03f, 4.022849025e-04f},
       {1.750028431e-01f, 6.532263011e-02f, 4.541070759e-01f, 1.241823286e-01f,
        3.931051493e-01f, 1.943016984e-02f},
       -1.175289631e+00},
      {PolicyType::kCma,
       /*prevAction=*/false,
       {2.278302272e-04f,  -1.241716905e-03f, 5.645786878e-04f,
        -7.799802697e-04f, 3.309206222e-04f,  -1.238322933e-03f,
        4.796523426e-04f,  -8.300653426e-04f, -3.180735512e-04f,
        -1.493447693e-03f, 6.954061682e-04f,  -5.906770821e-04f,
        4.204728757e-04f,  -1.435967861e-03f, -1.355679415e-04f,
        -6.308374577e-04f, -7.032803842e-05f, -1.632143278e-03f,
        -1.038832706e-03f, -7.648299215e-04f, 2.860568638e-04f,
        -1.196161029e-03f, 4.686328757e-04f,  -7.762577152e-04f},
       {-1.831374913e-01f, -1.828593165e-01f, -2.574456334e-01f,
        -7.971959561e-02f, -5.305172876e-02f, -1.854407638e-01f},
       -1.423876286e-01},
  };
  for (const Golden& g : goldens) {
    torch::manual_seed(11);
    ModelConfig c = tinyConfig(g.policy);
    c.seq2seq_prev_action = g.prevAction;
    auto policy = makePolicy(c);
    policy->eval();
    const auto instr = policy->encodeInstruction(randomTokens({4, 2}, 5, 23));
    const auto out = policy->forwardSequence(
        instr, randomInputs(c, 3, 2, {{2, 1}}), policy->initialHidden(2));
    const torch::Tensor logits = out.logits.flatten().contiguous();
    const torch::Tensor progress = out.progress.flatten().contiguous();
    ASSERT_EQ(logits.numel(), static_cast<int64_t>(g.logits.size()));
    ASSERT_EQ(progress.numel(), static_cast<int64_t>(g.progress.size()));
    // the same to 1e-5 of the largest output: on other vector units (AVX-512
    // against AVX2, without the pin) the values moved by up to 5.2e-7 of it;
    // a changed model moves them by about the whole of it
    const auto near = [&](const torch::Tensor& actual,
                          const std::vector<float>& golden, const char* what) {
      float scale = 0;
      for (float v : golden) scale = std::max(scale, std::abs(v));
      for (size_t i = 0; i < golden.size(); ++i)
        EXPECT_NEAR(actual[static_cast<int64_t>(i)].item<float>(), golden[i],
                    1e-5 * scale)
            << policyName(g.policy) << " " << what << " " << i;
    };
    near(logits, g.logits, "logit");
    near(progress, g.progress, "progress");
    EXPECT_NEAR(out.hidden.sum().item<double>(), g.hiddenSum, 1e-5)
        << policyName(g.policy);
  }
}

TEST(PolicyFactoryTest, PaperSizesGiveVlnCeParameterCounts) {
  // trainable counts of VLN-CE's nets without the visual CNNs and
  // embeddings, from the layer sizes in seq2seq_policy.py / cma_policy.py
  // (GRU: 3H(I+H) + 6H; Linear: in*out + out; LSTM: 4H(I+H) + 8H per dir)
  ModelConfig s2s;
  s2s.policy = PolicyType::kSeq2Seq;
  s2s.progress_monitor = true;
  ModelConfig cma = s2s;
  cma.policy = PolicyType::kCma;
  auto count = [](PolicyImpl& p) {
    int64_t n = 0;
    for (const auto& t : p.parameters())
      if (t.requires_grad()) n += t.numel();
    return n;
  };
  const int64_t lstm = 4 * 128 * (50 + 128) + 8 * 128;
  const int64_t s2sExpected = lstm + (2048 * 256 + 256) + (2048 * 128 + 128) +
                              (3 * 512 * (512 + 512) + 6 * 512) +
                              (512 * 4 + 4) + (512 + 1);
  EXPECT_EQ(count(*makePolicy(s2s)), s2sExpected);
  const int64_t cmaExpected =
      2 * lstm + 16 * 64 + 16 * 64 + (2112 * 256 + 256) +
      (192 * 16 * 128 + 128) + 5 * 32 + (3 * 512 * (416 + 512) + 6 * 512) +
      (512 * 256 + 256) + (256 * 256 + 256) + (256 * 256 + 256) +
      (2112 * 512 + 512) + (192 * 384 + 384) + (1184 * 512 + 512) +
      (3 * 512 * 1024 + 6 * 512) + (512 * 4 + 4) + (512 + 1);
  EXPECT_EQ(count(*makePolicy(cma)), cmaExpected);
}

}  // namespace
}  // namespace vln::models
