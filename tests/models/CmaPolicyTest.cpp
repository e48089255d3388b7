// CmaPolicy computes VLN-CE's CMANet function: checked against a direct,
// unoptimised transcription of cma_policy.py (every location projected by
// the key/value layer, position embeddings concatenated to the features,
// -1e8 instruction mask, one GRU cell per step).
#include "models/CmaPolicy.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "ModelTestUtil.h"

namespace vln::models {
namespace {

using test::randomInputs;
using test::randomTokens;
using test::tinyConfig;

torch::Tensor gruLoop(MaskedGruImpl& m, const torch::Tensor& x, torch::Tensor h,
                      const torch::Tensor& notDone) {
  std::vector<torch::Tensor> out;
  for (int64_t t = 0; t < x.size(0); ++t) {
    const auto& w = m.gru->all_weights();  // w_ih, w_hh, b_ih, b_hh
    h = torch::gru_cell(x[t], h * notDone[t].unsqueeze(-1), w[0], w[1], w[2],
                        w[3]);
    out.push_back(h);
  }
  return torch::stack(out);
}

// VLN-CE's _attn: softmax((k . q) * scale - mask * 1e8) weighted sum of v
torch::Tensor attn(const torch::Tensor& q, const torch::Tensor& k,
                   const torch::Tensor& v, const torch::Tensor& padMask,
                   double scale) {
  torch::Tensor logits = torch::einsum("nc,nci->ni", {q, k});
  if (padMask.defined()) logits = logits - padMask.to(logits.dtype()) * 1e8;
  const torch::Tensor a = torch::softmax(logits * scale, 1);
  return torch::einsum("ni,nci->nc", {a, v});
}

TEST(CmaPolicyTest, MatchesDirectTranscriptionOfVlnCe) {
  torch::manual_seed(3);
  const ModelConfig c = tinyConfig(PolicyType::kCma);
  CmaPolicy policy(c);
  policy->to(torch::kDouble);
  const int64_t steps = 5, batch = 3, n = steps * batch;
  const PolicyInputs in =
      randomInputs(c, steps, batch, {{2, 1}}, torch::kDouble);
  const torch::Tensor tokens = randomTokens({6, 2, 4}, 7, c.vocab_size);
  const torch::Tensor h0 =
      torch::randn({batch, 2, c.hidden_size}, torch::kDouble);

  const auto fast =
      policy->forwardSequence(policy->encodeInstruction(tokens), in, h0);

  // the direct form, step by step through cma_policy.py's forward
  const int64_t half = c.hidden_size / 2;
  const double scale = 1.0 / std::sqrt(static_cast<double>(half));
  const auto instr = policy->instruction_encoder->forward(tokens);
  // instruction_embedding is [B, D, L] there, repeated for every step
  const torch::Tensor instrStates = instr.states.transpose(1, 2)
                                        .unsqueeze(0)
                                        .expand({steps, -1, -1, -1})
                                        .reshape({n, -1, instr.states.size(1)});
  const torch::Tensor padMask = instr.mask.logical_not()
                                    .unsqueeze(0)
                                    .expand({steps, -1, -1})
                                    .reshape({n, -1});
  auto withPositions = [&](const torch::Tensor& f, torch::nn::Embedding& e) {
    const torch::Tensor flat = f.reshape({n, f.size(2), -1});
    const int64_t positions = flat.size(2);
    const torch::Tensor pos =
        e->weight.view({1, -1, positions}).expand({n, -1, positions});
    return torch::cat({flat, pos}, 1);  // [N, C + E, P]
  };
  const torch::Tensor rgb =
      withPositions(in.rgb, policy->rgb_spatial_embedding);
  const torch::Tensor depth =
      withPositions(in.depth, policy->depth_spatial_embedding);
  const torch::Tensor prev = policy->prev_action_embedding(
      ((in.prev_actions + 1) * in.not_done).to(torch::kLong).view(-1));
  const torch::Tensor rgbIn = torch::relu(policy->rgb_linear(rgb.mean(2)));
  const torch::Tensor depthIn =
      torch::relu(policy->depth_linear(depth.flatten(1)));
  const torch::Tensor state =
      gruLoop(*policy->state_encoder,
              torch::cat({rgbIn, depthIn, prev}, 1).view({steps, batch, -1}),
              h0.select(1, 0), in.not_done)
          .view({n, -1});
  const torch::Tensor textK =
      torch::einsum("oc,ncl->nol", {policy->text_k->weight, instrStates}) +
      policy->text_k->bias.view({1, -1, 1});
  const torch::Tensor text =
      attn(policy->state_q(state), textK, instrStates, padMask, scale);
  auto kv = [&](torch::nn::Linear& layer, const torch::Tensor& x) {
    return torch::einsum("oc,ncp->nop", {layer->weight, x}) +
           layer->bias.view({1, -1, 1});
  };
  const torch::Tensor rgbKv = kv(policy->rgb_kv, rgb);
  const torch::Tensor depthKv = kv(policy->depth_kv, depth);
  const torch::Tensor textQ = policy->text_q(text);
  const torch::Tensor rgbAtt =
      attn(textQ, rgbKv.slice(1, 0, half), rgbKv.slice(1, half), {}, scale);
  const torch::Tensor depthAtt =
      attn(textQ, depthKv.slice(1, 0, half), depthKv.slice(1, half), {}, scale);
  const torch::Tensor x = torch::relu(policy->second_state_compress(
      torch::cat({state, text, rgbAtt, depthAtt, prev}, 1)));
  const torch::Tensor action =
      gruLoop(*policy->second_state_encoder, x.view({steps, batch, -1}),
              h0.select(1, 1), in.not_done);
  const torch::Tensor logits = policy->action_head(action);
  const torch::Tensor progress =
      torch::tanh(policy->progress_monitor(action)).squeeze(-1);

  EXPECT_TRUE(torch::allclose(fast.logits, logits, 1e-9, 1e-11));
  EXPECT_TRUE(torch::allclose(fast.progress, progress, 1e-9, 1e-11));
  EXPECT_TRUE(torch::allclose(fast.hidden.select(1, 1), action[steps - 1], 1e-9,
                              1e-11));
}

TEST(CmaPolicyTest, WithoutInstructionVisualQueryIsLearnedConstant) {
  ModelConfig c = tinyConfig(PolicyType::kCma);
  c.no_instruction = true;
  CmaPolicy policy(c);
  ASSERT_TRUE(policy->visual_query.defined());
  EXPECT_EQ(policy->visual_query.size(0), c.hidden_size / 2);
  EXPECT_FALSE(policy->text_q);
  // second GRU input: state, RGB value, depth value, previous action
  EXPECT_EQ(policy->second_state_compress->weight.size(1),
            c.hidden_size + c.rgb_projection_size + c.depth_projection_size +
                c.prev_action_embedding_dim);
}

TEST(CmaPolicyTest, TurnCountsFollowTheActions) {
  // one row: STOP id 0 at the start (not_done 0), then left, left, right,
  // left, forward, right, right, look up (id 4: no turn), then a reset
  const torch::Tensor actions =
      torch::tensor({0, 2, 2, 3, 2, 1, 3, 3, 4, 2}, torch::kInt64).unsqueeze(1);
  torch::Tensor notDone = torch::ones({10, 1});
  notDone[0] = 0;
  notDone[9] = 0;
  const torch::Tensor counts =
      turnCounts(actions, notDone, torch::full({1}, 5.0));
  EXPECT_TRUE(torch::equal(
      counts.squeeze(1),
      torch::tensor({0.f, 1.f, 2.f, 1.f, 2.f, 0.f, -1.f, -2.f, -2.f, 0.f})))
      << counts;

  // a carried count continues; it saturates at kMaxTurnCount either way
  const torch::Tensor lefts = torch::full({15, 2}, kTurnLeftAction);
  lefts.select(1, 1).fill_(kTurnRightAction);
  const torch::Tensor carried =
      turnCounts(lefts, torch::ones({15, 2}), torch::tensor({3.f, -3.f}));
  EXPECT_EQ(carried[0][0].item<float>(), 4.f);
  EXPECT_EQ(carried[0][1].item<float>(), -4.f);
  EXPECT_EQ(carried[14][0].item<float>(), static_cast<float>(kMaxTurnCount));
  EXPECT_EQ(carried[14][1].item<float>(), -static_cast<float>(kMaxTurnCount));
}

TEST(CmaPolicyTest, TurnCountChangesTheActionAndRidesInTheState) {
  ModelConfig c = tinyConfig(PolicyType::kCma);
  c.turn_count_embedding_dim = 8;
  CmaPolicy policy(c);
  policy->eval();
  torch::NoGradGuard noGrad;
  const auto instr = policy->encodeInstruction(randomTokens({4, 6}, 6, 23));
  // two rows that see the same observations and the same last action
  // (TURN_LEFT) after different histories: 3 lefts against 1 right, 3 lefts
  PolicyInputs in = randomInputs(c, 4, 2);
  in.rgb.select(1, 1).copy_(in.rgb.select(1, 0));
  in.depth.select(1, 1).copy_(in.depth.select(1, 0));
  in.prev_actions.select(1, 0).copy_(torch::tensor({0, 2, 2, 2}));
  in.prev_actions.select(1, 1).copy_(torch::tensor({0, 3, 2, 2}));
  const auto out = policy->forwardSequence(instr, in, policy->initialHidden(2));
  EXPECT_EQ(out.hidden[0][2][0].item<float>(), 3.f);
  EXPECT_EQ(out.hidden[1][2][0].item<float>(), 1.f);
  // the second GRU input widens by the embedding, as the first's does
  EXPECT_EQ(policy->second_state_compress->weight.size(1),
            c.hidden_size + c.instructionStateSize() + c.rgb_projection_size +
                c.depth_projection_size + c.prev_action_embedding_dim + 8);
  EXPECT_FALSE(torch::allclose(out.logits[3][0], out.logits[3][1]));
}

TEST(CmaPolicyTest, TurnCountNeedsCma) {
  ModelConfig c = tinyConfig(PolicyType::kSeq2Seq);
  c.turn_count_embedding_dim = 8;
  EXPECT_THAT([&] { c.validate(); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  ::testing::HasSubstr("turn_count_embedding_dim")));
}

TEST(CmaPolicyTest, RejectsSeq2SeqConfig) {
  EXPECT_THROW(CmaPolicy(tinyConfig(PolicyType::kSeq2Seq)),
               std::invalid_argument);
}

}  // namespace
}  // namespace vln::models
