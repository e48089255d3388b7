// Tests src/models/WaypointCmaPolicy.cpp: shapes, the candidate mask, that
// stepping equals the sequence, that candidates read the view at their
// heading, the no-instruction ablation, training-only dropout, the heading
// harmonics' input widths, the second (leg) attention, the words' mask of
// each decision, the goal match, and that it can fit labels.

#include "models/WaypointCmaPolicy.h"

#include <gtest/gtest.h>

#include <cmath>

#include "ModelTestUtil.h"

namespace vln::models {
namespace {

constexpr int64_t kViews = 12;
constexpr int64_t kRgb = 20;
constexpr int64_t kDepth = 16;
constexpr int64_t kSlots = 4;

ModelConfig config() {
  ModelConfig c = test::tinyConfig(PolicyType::kCma);
  // the tiny config's progress monitor is a head of its own here (its
  // test below); these tests keep the draws they were written with
  c.progress_monitor = false;
  c.fine_tune_embeddings = true;
  return c;
}

// inputs [T, B, ...]: random features, `count[b]` candidates per row at
// random headings and distances, previous decisions, episode starts at t = 0
WaypointPolicyInputs randomInputs(int64_t T,
                                  const std::vector<int64_t>& count) {
  const auto B = static_cast<int64_t>(count.size());
  WaypointPolicyInputs in;
  in.rgb = torch::randn({T, B, kViews, kRgb});
  in.depth = torch::rand({T, B, kViews, kDepth});
  in.candidates = torch::stack({torch::rand({T, B, kSlots}) * 6.28,
                                torch::rand({T, B, kSlots}) * 2.75 + 0.25},
                               -1);
  in.candidate_mask = torch::zeros({T, B, kSlots}, torch::kBool);
  for (int64_t b = 0; b < B; ++b)
    in.candidate_mask.select(1, b).slice(1, 0, count[static_cast<size_t>(b)]) =
        true;
  in.prev = torch::rand({T, B, 2});
  in.not_done = torch::ones({T, B});
  in.not_done[0] = 0.0f;
  return in;
}

WaypointPolicyInputs stepOf(const WaypointPolicyInputs& in, int64_t t) {
  return {in.rgb[t],
          in.depth[t],
          in.candidates[t],
          in.candidate_mask[t],
          in.prev[t],
          in.not_done[t],
          in.text_mask.defined() ? in.text_mask[t] : torch::Tensor()};
}

TEST(WaypointCmaPolicyTest, LogitsAreStopThenTheCandidatesMasked) {
  torch::manual_seed(0);
  WaypointCmaPolicy policy(config(), kViews, kRgb, kDepth);
  const auto instruction =
      policy->encodeInstruction(test::randomTokens({5, 3}, 6, 23));
  const WaypointPolicyInputs in = randomInputs(3, {2, 0});
  const WaypointPolicyOutputs out =
      policy->forwardSequence(instruction, in, policy->initialHidden(2));
  ASSERT_EQ(out.logits.sizes(), (std::vector<int64_t>{3, 2, kSlots + 1}));
  ASSERT_EQ(out.hidden.sizes(),
            (std::vector<int64_t>{2, 2, config().hidden_size}));
  // STOP and the real candidates are finite, empty slots -inf
  EXPECT_TRUE(torch::isfinite(out.logits.select(1, 0).slice(1, 0, 3))
                  .all()
                  .item<bool>());
  EXPECT_TRUE(
      torch::isinf(out.logits.select(1, 0).slice(1, 3)).all().item<bool>());
  EXPECT_TRUE(torch::isfinite(out.logits.select(1, 1).slice(1, 0, 1))
                  .all()
                  .item<bool>());
  EXPECT_TRUE(
      torch::isinf(out.logits.select(1, 1).slice(1, 1)).all().item<bool>());
}

TEST(WaypointCmaPolicyTest, SteppingEqualsTheSequence) {
  torch::manual_seed(1);
  WaypointCmaPolicy policy(config(), kViews, kRgb, kDepth);
  policy->eval();
  torch::NoGradGuard noGrad;
  const auto instruction =
      policy->encodeInstruction(test::randomTokens({6, 2, 4}, 6, 23));
  const WaypointPolicyInputs in = randomInputs(4, {4, 1, 3});
  const WaypointPolicyOutputs sequence =
      policy->forwardSequence(instruction, in, policy->initialHidden(3));
  torch::Tensor hidden = policy->initialHidden(3);
  for (int64_t t = 0; t < 4; ++t) {
    const WaypointPolicyOutputs step =
        policy->step(instruction, stepOf(in, t), hidden);
    const torch::Tensor finite = torch::isfinite(sequence.logits[t]);
    EXPECT_TRUE(torch::equal(finite, torch::isfinite(step.logits)));
    EXPECT_TRUE(torch::allclose(step.logits.masked_fill(~finite, 0),
                                sequence.logits[t].masked_fill(~finite, 0),
                                1e-5, 1e-5))
        << "t = " << t;
    hidden = step.hidden;
  }
  EXPECT_TRUE(torch::allclose(hidden, sequence.hidden, 1e-5, 1e-5));
}

// waypoint_agent.leg_words_only's mask: each decision attends to its
// allowed words only (wider masks are cut to the instruction), a row that
// allows none of its words reads them all, and stepping honours it too
TEST(WaypointCmaPolicyTest, TheTextMaskLimitsTheWordsEachDecisionAttendsTo) {
  torch::manual_seed(3);
  WaypointCmaPolicy policy(config(), kViews, kRgb, kDepth);
  policy->eval();
  torch::NoGradGuard noGrad;
  const auto instruction =
      policy->encodeInstruction(test::randomTokens({6, 4}, 6, 23));
  WaypointPolicyInputs in = randomInputs(3, {3, 2});
  const WaypointPolicyOutputs all =
      policy->forwardSequence(instruction, in, policy->initialHidden(2));

  // 8 columns for 6 tokens; row 1's tokens 4-5 are padding
  in.text_mask = torch::zeros({3, 2, 8}, torch::kBool);
  in.text_mask[0][0].slice(0, 0, 2) = true;
  in.text_mask[1][0].slice(0, 2, 5) = true;
  in.text_mask[2][0].slice(0, 5, 8) = true;
  in.text_mask[0][1] = true;                 // every word
  in.text_mask[1][1].slice(0, 4, 8) = true;  // padding only: none
  in.text_mask[2][1][1] = true;
  const WaypointPolicyOutputs masked =
      policy->forwardSequence(instruction, in, policy->initialHidden(2));
  const torch::Tensor weights = masked.text_attention;  // [3, 2, 6]
  ASSERT_EQ(weights.sizes(), (std::vector<int64_t>{3, 2, 6}));
  const torch::Tensor allowed =
      in.text_mask.slice(2, 0, 6).logical_and(instruction.mask.unsqueeze(0));
  for (int64_t t = 0; t < 3; ++t)
    for (int64_t b = 0; b < 2; ++b) {
      const torch::Tensor w = weights[t][b];
      if (allowed[t][b].any().item<bool>()) {
        EXPECT_EQ(
            w.masked_select(allowed[t][b].logical_not()).sum().item<float>(),
            0.0f)
            << t << ", " << b;
      }
      EXPECT_NEAR(w.sum().item<float>(), 1.0f, 1e-5);
    }
  EXPECT_NEAR(weights[2][1][1].item<float>(), 1.0f, 1e-6);
  // all words allowed at the first decision of row 1: as without a mask
  EXPECT_TRUE(
      torch::allclose(masked.text_attention[0][1], all.text_attention[0][1]));
  // no word of row 1 allowed at its second decision: all of them read
  EXPECT_GT(weights[1][1].slice(0, 0, 4).min().item<float>(), 0.0f);
  // the first row reads other words and chooses otherwise
  EXPECT_FALSE(torch::allclose(masked.logits[0][0].slice(0, 0, 4),
                               all.logits[0][0].slice(0, 0, 4)));

  torch::Tensor hidden = policy->initialHidden(2);
  for (int64_t t = 0; t < 3; ++t) {
    const WaypointPolicyOutputs step =
        policy->step(instruction, stepOf(in, t), hidden);
    EXPECT_TRUE(torch::allclose(step.text_attention, weights[t], 1e-5, 1e-5))
        << "t = " << t;
    hidden = step.hidden;
  }
}

TEST(WaypointCmaPolicyTest, ACandidateReadsTheViewAtItsHeading) {
  torch::manual_seed(2);
  WaypointCmaPolicy policy(config(), kViews, kRgb, kDepth);
  policy->eval();
  torch::NoGradGuard noGrad;
  const auto instruction =
      policy->encodeInstruction(test::randomTokens({4}, 4, 23));
  WaypointPolicyInputs in = randomInputs(1, {1});
  in.candidates[0][0][0][0] = 3.0 * 6.283185307 / kViews;  // view 3's axis
  const torch::Tensor before =
      policy->forwardSequence(instruction, in, policy->initialHidden(1)).logits;
  // changing view 3 alone moves the candidate's logit relative to STOP by
  // more than changing view 7 does (which only reaches it through the
  // attended summaries)
  auto changed = [&](int64_t view) {
    WaypointPolicyInputs other = in;
    other.rgb = in.rgb.clone();
    other.rgb[0][0][view] += 3.0;
    const torch::Tensor logits =
        policy->forwardSequence(instruction, other, policy->initialHidden(1))
            .logits;
    return logits[0][0][1] - logits[0][0][0];
  };
  const double base = (before[0][0][1] - before[0][0][0]).item<double>();
  EXPECT_GT(std::abs(changed(3).item<double>() - base),
            std::abs(changed(7).item<double>() - base));
}

// model.goal_match: the RGB features reach the policy only as their match
// with the goal's labels. A feature the goal does not name changes no
// logit, a named one changes STOP's and the candidates'; stepping equals
// the sequence; without goal_labels the policy says what it needs
TEST(WaypointCmaPolicyTest, TheGoalMatchReadsOnlyTheNamedLabels) {
  torch::manual_seed(4);
  ModelConfig c = config();
  c.rgb_semantic_outputs = kRgb;
  c.goal_match = true;
  WaypointCmaPolicy policy(c, kViews, kRgb, kDepth);
  policy->eval();
  torch::NoGradGuard noGrad;
  const auto instruction =
      policy->encodeInstruction(test::randomTokens({5, 3}, 5, 23));
  WaypointPolicyInputs in = randomInputs(3, {3, 2});
  in.rgb = torch::rand({3, 2, kViews, kRgb}) * 0.5;  // probabilities
  // episode 0 names feature 2 (a category) and 9 (a colour), episode 1
  // feature 15 (a room)
  in.goal_labels = torch::zeros({2, kRgb});
  in.goal_labels[0][2] = 1.0f;
  in.goal_labels[0][9] = 2.0f;
  in.goal_labels[1][15] = 3.0f;
  const torch::Tensor base =
      policy->forwardSequence(instruction, in, policy->initialHidden(2)).logits;
  auto withFeature = [&](int64_t feature) {
    WaypointPolicyInputs other = in;
    other.rgb = in.rgb.clone();
    other.rgb.select(3, feature).select(2, 4) = 1.0f;  // view 4 shows it
    return policy->forwardSequence(instruction, other, policy->initialHidden(2))
        .logits;
  };
  const torch::Tensor finite = torch::isfinite(base);
  auto moved = [&](const torch::Tensor& logits, int64_t b, int64_t slot) {
    return (logits.select(1, b).select(1, slot) -
            base.select(1, b).select(1, slot))
        .abs()
        .max()
        .item<double>();
  };
  const torch::Tensor unnamed = withFeature(5);
  EXPECT_TRUE(torch::equal(unnamed.masked_fill(~finite, 0),
                           base.masked_fill(~finite, 0)))
      << "a label the goal does not name reached the logits";
  const torch::Tensor category = withFeature(2);
  EXPECT_GT(moved(category, 0, 0), 1e-4) << "STOP did not see the goal";
  EXPECT_GT(moved(category, 0, 1), 1e-4);
  EXPECT_LT(moved(category, 1, 0), 1e-7) << "episode 1 does not name it";
  EXPECT_GT(moved(withFeature(15), 1, 0), 1e-4);

  torch::Tensor hidden = policy->initialHidden(2);
  for (int64_t t = 0; t < 3; ++t) {
    WaypointPolicyInputs one = stepOf(in, t);
    one.goal_labels = in.goal_labels;
    const WaypointPolicyOutputs step = policy->step(instruction, one, hidden);
    const torch::Tensor f = torch::isfinite(base[t]);
    EXPECT_TRUE(torch::allclose(step.logits.masked_fill(~f, 0),
                                base[t].masked_fill(~f, 0), 1e-5, 1e-5))
        << "t = " << t;
    hidden = step.hidden;
  }

  in.goal_labels = torch::Tensor();
  try {
    policy->forwardSequence(instruction, in, policy->initialHidden(2));
    ADD_FAILURE() << "goal_match without goal_labels must be an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("goal_labels"), std::string::npos)
        << e.what();
  }
}

// model.progress_monitor: one value in (-1, 1) per decision, the same
// stepping as in a sequence, read from GRU2's state (the logits unchanged
// by the head's presence); none without the option
TEST(WaypointCmaPolicyTest, TheProgressMonitorReadsTheSecondState) {
  ModelConfig c = config();
  c.progress_monitor = true;
  torch::manual_seed(4);
  WaypointCmaPolicy policy(c, kViews, kRgb, kDepth);
  policy->eval();
  torch::NoGradGuard noGrad;
  const torch::Tensor tokens = test::randomTokens({5, 3}, 6, 23);
  const auto instruction = policy->encodeInstruction(tokens);
  const WaypointPolicyInputs in = randomInputs(3, {2, 3});
  const WaypointPolicyOutputs sequence =
      policy->forwardSequence(instruction, in, policy->initialHidden(2));
  ASSERT_EQ(sequence.progress.sizes(), (std::vector<int64_t>{3, 2}));
  EXPECT_TRUE(sequence.progress.abs().lt(1.0).all().item<bool>());
  // by hand from the state after the last step: tanh(W_p h2)
  const torch::Tensor last =
      torch::tanh(policy->progress_monitor(sequence.hidden.select(1, 1)))
          .squeeze(-1);
  EXPECT_TRUE(torch::allclose(last, sequence.progress[2], 1e-6, 1e-6));
  torch::Tensor hidden = policy->initialHidden(2);
  for (int64_t t = 0; t < 3; ++t) {
    const WaypointPolicyOutputs step =
        policy->step(instruction, stepOf(in, t), hidden);
    ASSERT_EQ(step.progress.sizes(), (std::vector<int64_t>{2}));
    EXPECT_TRUE(
        torch::allclose(step.progress, sequence.progress[t], 1e-5, 1e-5));
    hidden = step.hidden;
  }
  torch::manual_seed(4);
  WaypointCmaPolicy plain(config(), kViews, kRgb, kDepth);
  plain->eval();
  const WaypointPolicyOutputs without = plain->forwardSequence(
      plain->encodeInstruction(tokens), in, plain->initialHidden(2));
  EXPECT_FALSE(without.progress.defined());
  const torch::Tensor finite = torch::isfinite(without.logits);
  EXPECT_TRUE(torch::equal(without.logits.masked_fill(~finite, 0),
                           sequence.logits.masked_fill(~finite, 0)));
}

TEST(WaypointCmaPolicyTest, WithoutTheInstructionThereIsNoEncoder) {
  ModelConfig c = config();
  c.no_instruction = true;
  WaypointCmaPolicy policy(c, kViews, kRgb, kDepth);
  EXPECT_TRUE(policy->instruction_encoder.is_empty());
  const EncodedInstruction none = policy->encodeInstruction({});
  const WaypointPolicyOutputs out = policy->forwardSequence(
      none, randomInputs(2, {3, 2}), policy->initialHidden(2));
  EXPECT_EQ(out.logits.sizes(), (std::vector<int64_t>{2, 2, kSlots + 1}));
}

// model.dropout: each training pass draws new masks; evaluation and a zero
// rate are deterministic and agree with each other
TEST(WaypointCmaPolicyTest, DropoutActsOnlyWhileTraining) {
  torch::manual_seed(4);
  ModelConfig c = config();
  c.dropout = 0.3;
  WaypointCmaPolicy policy(c, kViews, kRgb, kDepth);
  torch::manual_seed(4);
  WaypointCmaPolicy plain(config(), kViews, kRgb, kDepth);
  const torch::Tensor tokens = test::randomTokens({5, 3}, 6, 23);
  const WaypointPolicyInputs in = randomInputs(3, {4, 2});
  torch::NoGradGuard noGrad;
  auto logits = [&](WaypointCmaPolicy& p) {
    const torch::Tensor l =
        p->forwardSequence(p->encodeInstruction(tokens), in,
                           p->initialHidden(2))
            .logits;
    return l.masked_fill(torch::isinf(l), 0);
  };
  policy->train();
  EXPECT_FALSE(torch::allclose(logits(policy), logits(policy)));
  policy->eval();
  plain->train();
  const torch::Tensor evaluated = logits(policy);
  EXPECT_TRUE(torch::equal(evaluated, logits(policy)));
  EXPECT_TRUE(torch::allclose(evaluated, logits(plain), 1e-6, 1e-6));
}

TEST(WaypointCmaPolicyTest, HeadingHarmonicsWidenOnlyTheHeadingInputs) {
  ModelConfig c = config();
  WaypointCmaPolicy one(c, kViews, kRgb, kDepth);
  c.heading_harmonics = 3;
  WaypointCmaPolicy three(c, kViews, kRgb, kDepth);
  // one harmonic keeps the layer shapes checkpoints have always had:
  // sin, cos (views); sin, cos, distance, start (previous decision)
  EXPECT_EQ(one->view_linear->weight.size(1),
            c.rgb_projection_size + c.depth_projection_size + 2);
  EXPECT_EQ(one->prev_linear->weight.size(1), 4);
  EXPECT_EQ(one->candidate_linear->weight.size(1), c.hidden_size + 3);
  EXPECT_EQ(three->view_linear->weight.size(1),
            c.rgb_projection_size + c.depth_projection_size + 6);
  EXPECT_EQ(three->prev_linear->weight.size(1), 8);
  EXPECT_EQ(three->candidate_linear->weight.size(1), c.hidden_size + 7);
  // headings 2 pi apart are the same heading
  torch::manual_seed(4);
  three->eval();
  torch::NoGradGuard noGrad;
  const auto instruction =
      three->encodeInstruction(test::randomTokens({4}, 4, 23));
  WaypointPolicyInputs in = randomInputs(2, {3});
  WaypointPolicyInputs turned = in;
  turned.candidates = in.candidates.clone();
  turned.candidates.select(-1, 0) += 6.283185307179586;
  turned.prev = in.prev.clone();
  turned.prev.select(-1, 0) -= 6.283185307179586;
  EXPECT_TRUE(torch::allclose(
      three->forwardSequence(instruction, in, three->initialHidden(1)).logits,
      three->forwardSequence(instruction, turned, three->initialHidden(1))
          .logits,
      1e-4, 1e-4));
}

// model.leg_attention adds one query layer and widens what reads the
// attended words; text_attention then reports the second attention (here
// made uniform over the real tokens by zeroing its query)
TEST(WaypointCmaPolicyTest, LegAttentionIsASecondAttentionOverTheWords) {
  ModelConfig c = config();
  WaypointCmaPolicy plain(c, kViews, kRgb, kDepth);
  c.leg_attention = true;
  EXPECT_NO_THROW(c.validate());
  WaypointCmaPolicy leg(c, kViews, kRgb, kDepth);
  ASSERT_FALSE(plain->leg_q);
  ASSERT_TRUE(leg->leg_q);
  const int64_t textDim = c.instructionStateSize();
  EXPECT_EQ(leg->second_state_compress->weight.size(1),
            plain->second_state_compress->weight.size(1) + textDim);
  EXPECT_EQ(leg->query_linear->weight.size(1),
            plain->query_linear->weight.size(1) + textDim);

  torch::manual_seed(6);
  leg->eval();
  torch::NoGradGuard noGrad;
  leg->leg_q->weight.zero_();
  leg->leg_q->bias.zero_();
  // two instructions of 4 and 2 tokens
  const auto instruction = leg->encodeInstruction(
      torch::tensor({{5, 6, 7, 8}, {9, 10, 0, 0}}, torch::kLong));
  const WaypointPolicyOutputs out = leg->forwardSequence(
      instruction, randomInputs(3, {2, 3}), leg->initialHidden(2));
  ASSERT_EQ(out.text_attention.sizes(), (torch::IntArrayRef{3, 2, 4}));
  const torch::Tensor uniform =
      torch::tensor({{0.25f, 0.25f, 0.25f, 0.25f}, {0.5f, 0.5f, 0.0f, 0.0f}})
          .expand({3, 2, 4});
  EXPECT_TRUE(torch::allclose(out.text_attention, uniform, 1e-6, 1e-6));
  // the plain policy's first attention is not uniform (at a fresh
  // initialisation its scores differ by only about 1e-3, so the check
  // uses the tolerance that held the zeroed attention uniform above)
  const WaypointPolicyOutputs first =
      plain->forwardSequence(plain->encodeInstruction(torch::tensor(
                                 {{5, 6, 7, 8}, {9, 10, 0, 0}}, torch::kLong)),
                             randomInputs(3, {2, 3}), plain->initialHidden(2));
  EXPECT_FALSE(torch::allclose(first.text_attention, uniform, 1e-6, 1e-6));

  c.no_instruction = true;
  EXPECT_THROW(c.validate(), std::invalid_argument);
}

// the clause tracker's clauses of two instructions of 6 and 4 tokens
// (randomTokens({6, 4}, ..)), in 8 columns: four clauses, and two
torch::Tensor clausesOfTwoInstructions() {
  return torch::tensor(
      {{0, 0, 1, 1, 2, 3, -1, -1}, {0, 0, 0, 1, -1, -1, -1, -1}}, torch::kLong);
}

// model.clause_tracker: the pointer starts at clause_start, never moves
// back nor more than two clauses, stays within the row's clauses (-inf
// logits past them), and each decision reads the words of its window; an
// episode that follows the oracle reads its (clamped) clauses; stepping
// with the last pointer as clause_start computes what the sequence does
TEST(WaypointCmaPolicyTest, TheClauseTrackerMovesAPointerAlongTheClauses) {
  ModelConfig c = config();
  c.clause_tracker = true;
  c.clause_window = 1;
  EXPECT_NO_THROW(c.validate());
  torch::manual_seed(8);
  WaypointCmaPolicy policy(c, kViews, kRgb, kDepth);
  ASSERT_TRUE(policy->clause_score);
  policy->eval();
  torch::NoGradGuard noGrad;
  const auto instruction =
      policy->encodeInstruction(test::randomTokens({6, 4}, 6, 23));
  constexpr int64_t T = 5;
  WaypointPolicyInputs in = randomInputs(T, {3, 2});
  in.clause_of_token = clausesOfTwoInstructions();
  in.clause_start = torch::tensor({1, 0}, torch::kLong);
  EXPECT_THROW(policy->forwardSequence(
                   instruction,
                   [&] {
                     WaypointPolicyInputs both = in;
                     both.text_mask = torch::ones({T, 2, 8}, torch::kBool);
                     return both;
                   }(),
                   policy->initialHidden(2)),
               std::invalid_argument);
  // steer row 0 to advance one clause at a time: E_1 dominates
  policy->clause_advance[1].fill_(3.0f);
  policy->clause_score->weight.fill_(1.0f);
  const WaypointPolicyOutputs own =
      policy->forwardSequence(instruction, in, policy->initialHidden(2));
  ASSERT_EQ(own.clause_logits.sizes(),
            (std::vector<int64_t>{T, 2, kClauseAdvances}));
  const std::vector<int64_t> counts{4, 2};
  for (int64_t b = 0; b < 2; ++b) {
    EXPECT_EQ(own.clause_before[0][b].item<int64_t>(),
              in.clause_start[b].item<int64_t>());
    for (int64_t t = 0; t < T; ++t) {
      const int64_t before = own.clause_before[t][b].item<int64_t>();
      const int64_t read = own.clause_pointer[t][b].item<int64_t>();
      EXPECT_GE(read, before);
      EXPECT_LE(read, before + 2);
      EXPECT_LT(read, counts[static_cast<size_t>(b)]);
      if (t > 0) {
        EXPECT_EQ(before, own.clause_pointer[t - 1][b].item<int64_t>());
      }
      for (int64_t a = 0; a < kClauseAdvances; ++a)
        EXPECT_EQ(std::isinf(own.clause_logits[t][b][a].item<float>()),
                  before + a >= counts[static_cast<size_t>(b)]);
      // the attention rests on the words of clause `read` alone
      const torch::Tensor words =
          in.clause_of_token[b].slice(0, 0, 6).eq(read).logical_and(
              instruction.mask[b]);
      EXPECT_NEAR(
          own.text_attention[t][b].masked_select(words).sum().item<float>(),
          1.0f, 1e-5);
    }
  }
  EXPECT_EQ(own.clause_pointer[0][0].item<int64_t>(), 2);
  EXPECT_EQ(own.clause_pointer[T - 1][0].item<int64_t>(), 3);
  EXPECT_FALSE(own.clause_targets.defined());

  // row 0 follows the oracle's clauses (7 is past its last: 3), row 1 not
  WaypointPolicyInputs taught = in;
  taught.clause_targets =
      torch::tensor({{0, 0}, {2, 0}, {2, 1}, {7, 1}, {-1, 1}}, torch::kLong);
  taught.clause_teacher = torch::tensor({true, false});
  const WaypointPolicyOutputs teacher =
      policy->forwardSequence(instruction, taught, policy->initialHidden(2));
  EXPECT_TRUE(torch::equal(teacher.clause_pointer.select(1, 0),
                           torch::tensor({0, 2, 2, 3, 0}, torch::kLong)));
  EXPECT_TRUE(torch::equal(teacher.clause_targets.select(1, 0),
                           torch::tensor({0, 2, 2, 3, -1}, torch::kLong)));
  EXPECT_TRUE(torch::equal(teacher.clause_pointer.select(1, 1),
                           own.clause_pointer.select(1, 1)));

  // stepping: each step starts where the last one's pointer ended
  torch::Tensor hidden = policy->initialHidden(2);
  torch::Tensor pointer = in.clause_start;
  for (int64_t t = 0; t < T; ++t) {
    WaypointPolicyInputs one = stepOf(in, t);
    one.clause_of_token = in.clause_of_token;
    one.clause_start = pointer;
    const WaypointPolicyOutputs step = policy->step(instruction, one, hidden);
    EXPECT_TRUE(torch::equal(step.clause_pointer, own.clause_pointer[t]));
    const torch::Tensor finite = torch::isfinite(own.logits[t]);
    EXPECT_TRUE(torch::allclose(step.logits.masked_fill(~finite, 0),
                                own.logits[t].masked_fill(~finite, 0), 1e-5,
                                1e-5))
        << "t = " << t;
    hidden = step.hidden;
    pointer = step.clause_pointer;
  }

  c.no_instruction = true;
  EXPECT_THROW(c.validate(), std::invalid_argument);
}

// model.clause_tracker_memory: the head reads GRU2's state before each
// decision as well; a training sequence runs step by step, so it equals
// stepping, and GRU2's state changes the head's logits from the second
// decision on (at the first it is zero)
TEST(WaypointCmaPolicyTest, TheClauseTrackersMemoryIsTheSecondStateBefore) {
  ModelConfig c = config();
  c.clause_tracker = true;
  c.clause_tracker_memory = true;
  EXPECT_NO_THROW(c.validate());
  torch::manual_seed(9);
  WaypointCmaPolicy policy(c, kViews, kRgb, kDepth);
  ASSERT_TRUE(policy->clause_memory);
  policy->eval();
  torch::NoGradGuard noGrad;
  const auto instruction =
      policy->encodeInstruction(test::randomTokens({6, 4}, 6, 23));
  constexpr int64_t T = 4;
  WaypointPolicyInputs in = randomInputs(T, {3, 2});
  in.clause_of_token = clausesOfTwoInstructions();
  in.clause_targets =
      torch::tensor({{0, 0}, {1, 0}, {2, 1}, {3, 1}}, torch::kLong);
  in.clause_teacher = torch::tensor({true, false});
  const WaypointPolicyOutputs sequence =
      policy->forwardSequence(instruction, in, policy->initialHidden(2));
  ASSERT_EQ(sequence.clause_logits.sizes(),
            (std::vector<int64_t>{T, 2, kClauseAdvances}));
  ASSERT_EQ(sequence.logits.sizes(), (std::vector<int64_t>{T, 2, kSlots + 1}));
  EXPECT_TRUE(torch::equal(sequence.clause_pointer.select(1, 0),
                           torch::tensor({0, 1, 2, 3}, torch::kLong)));
  torch::Tensor hidden = policy->initialHidden(2);
  torch::Tensor pointer = torch::zeros({2}, torch::kLong);
  for (int64_t t = 0; t < T; ++t) {
    WaypointPolicyInputs one = stepOf(in, t);
    one.clause_of_token = in.clause_of_token;
    one.clause_start = pointer;
    one.clause_targets = in.clause_targets[t];
    one.clause_teacher = in.clause_teacher;
    const WaypointPolicyOutputs step = policy->step(instruction, one, hidden);
    EXPECT_TRUE(torch::equal(step.clause_pointer, sequence.clause_pointer[t]));
    const torch::Tensor finite = torch::isfinite(sequence.clause_logits[t]);
    EXPECT_TRUE(torch::allclose(
        step.clause_logits.masked_fill(~finite, 0),
        sequence.clause_logits[t].masked_fill(~finite, 0), 1e-5, 1e-5));
    hidden = step.hidden;
    pointer = step.clause_pointer;
  }
  EXPECT_TRUE(torch::allclose(hidden, sequence.hidden, 1e-5, 1e-5));
  // with W_m's weight zeroed the first decision (h2 zero) is the same,
  // later ones differ
  policy->clause_memory->weight.zero_();
  const WaypointPolicyOutputs forgetful =
      policy->forwardSequence(instruction, in, policy->initialHidden(2));
  const torch::Tensor finite = torch::isfinite(sequence.clause_logits);
  auto logitsAt = [&](const torch::Tensor& l, int64_t t) {
    return l.masked_fill(~finite, 0)[t];
  };
  EXPECT_TRUE(torch::allclose(logitsAt(forgetful.clause_logits, 0),
                              logitsAt(sequence.clause_logits, 0)));
  EXPECT_FALSE(torch::allclose(logitsAt(forgetful.clause_logits, 2),
                               logitsAt(sequence.clause_logits, 2)));

  c.clause_tracker = false;
  EXPECT_THROW(c.validate(), std::invalid_argument);
}

// model.candidate_text adds each candidate's own attention over the words
// to its key: with W_u zeroed the logits are the plain policy's, and the
// step mode computes what the sequence mode does
TEST(WaypointCmaPolicyTest, CandidateTextAddsTheWordsACandidateReadsToItsKey) {
  ModelConfig c = config();
  torch::manual_seed(8);
  WaypointCmaPolicy plain(c, kViews, kRgb, kDepth);
  c.candidate_text = true;
  EXPECT_NO_THROW(c.validate());
  WaypointCmaPolicy reading(c, kViews, kRgb, kDepth);
  ASSERT_FALSE(plain->candidate_text_q);
  ASSERT_TRUE(reading->candidate_text_q);
  EXPECT_EQ(reading->candidate_text_linear->weight.size(1),
            c.instructionStateSize());
  plain->eval();
  reading->eval();
  torch::NoGradGuard noGrad;
  // the shared parameters equal, the new ones aside
  const auto own = reading->named_parameters();
  for (const auto& p : plain->named_parameters()) own[p.key()].copy_(p.value());
  const torch::Tensor tokens =
      torch::tensor({{5, 6, 7, 8}, {9, 10, 0, 0}}, torch::kLong);
  const WaypointPolicyInputs in = randomInputs(3, {4, 2});
  auto logits = [&](WaypointCmaPolicy& policy) {
    return policy
        ->forwardSequence(policy->encodeInstruction(tokens), in,
                          policy->initialHidden(2))
        .logits;
  };
  const torch::Tensor before = logits(plain);
  EXPECT_FALSE(torch::allclose(logits(reading), before, 1e-4, 1e-4));
  const torch::Tensor stepped =
      reading
          ->step(reading->encodeInstruction(tokens), stepOf(in, 0),
                 reading->initialHidden(2))
          .logits;
  EXPECT_TRUE(torch::allclose(stepped, logits(reading)[0], 1e-5, 1e-5));
  reading->candidate_text_linear->weight.zero_();
  reading->candidate_text_linear->bias.zero_();
  EXPECT_TRUE(torch::allclose(logits(reading), before, 1e-6, 1e-6));

  c.no_instruction = true;
  EXPECT_THROW(c.validate(), std::invalid_argument);
}

class WaypointCmaPolicyLearningTest : public testing::TestWithParam<int> {};

TEST_P(WaypointCmaPolicyLearningTest, LearnsToFollowLabels) {
  torch::manual_seed(3);
  ModelConfig c = config();
  c.heading_harmonics = GetParam();
  WaypointCmaPolicy policy(c, kViews, kRgb, kDepth);
  const torch::Tensor tokens = test::randomTokens({5, 4, 6, 3}, 6, 23);
  const WaypointPolicyInputs in = randomInputs(3, {4, 4, 3, 2});
  // labels among each row's valid choices (0 STOP, 1..count)
  const torch::Tensor labels =
      torch::tensor({{1, 2, 3, 0}, {4, 0, 1, 2}, {0, 3, 2, 1}}, torch::kLong);
  torch::optim::Adam optimizer(policy->parameters(), 1e-2);
  double loss = 0.0;
  for (int i = 0; i < 200; ++i) {
    const auto instruction = policy->encodeInstruction(tokens);
    const torch::Tensor logits =
        policy->forwardSequence(instruction, in, policy->initialHidden(4))
            .logits.reshape({12, kSlots + 1});
    const torch::Tensor l =
        torch::nn::functional::cross_entropy(logits, labels.reshape({12}));
    optimizer.zero_grad();
    l.backward();
    optimizer.step();
    loss = l.item<double>();
  }
  EXPECT_LT(loss, 0.05);
}

INSTANTIATE_TEST_SUITE_P(HeadingHarmonics, WaypointCmaPolicyLearningTest,
                         testing::Values(1, 4));

}  // namespace
}  // namespace vln::models
