// Properties shared by both policies (Policy.cpp, Seq2SeqPolicy.cpp,
// CmaPolicy.cpp): shapes, step mode == sequence mode, PAD invariance,
// ablations, gradients, save/load.
#include "models/Policy.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "ModelTestUtil.h"
#include "models/StateDict.h"
#include "support/TestPaths.h"

namespace vln::models {
namespace {

using test::randomInputs;
using test::randomTokens;
using test::stepOf;
using test::tinyConfig;
using ::testing::HasSubstr;

class PolicyTest : public ::testing::TestWithParam<PolicyType> {
 protected:
  void SetUp() override { torch::manual_seed(7); }
  ModelConfig config() const { return tinyConfig(GetParam()); }
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
            (std::vector<int64_t>{3, c.numRecurrentLayers(), c.hidden_size}));
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
      torch::randn({batch, c.numRecurrentLayers(), c.hidden_size});

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
      torch::randn({2, c.numRecurrentLayers(), c.hidden_size}, torch::kDouble);
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

INSTANTIATE_TEST_SUITE_P(BothPolicies, PolicyTest,
                         ::testing::Values(PolicyType::kSeq2Seq,
                                           PolicyType::kCma),
                         [](const auto& info) {
                           return std::string(policyName(info.param));
                         });

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
