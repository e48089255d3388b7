// Tests src/models/WaypointExport.cpp: the exported waypoint policy, loaded
// back by torch::jit::load (and by Python's torch.jit.load when available),
// reproduces WaypointCmaPolicyImpl::step() on raw panoramas and on features,
// with masked candidate slots, episode starts mid-batch and the ablations;
// an included candidate predictor gives its heatmap and suppresses it as
// waypoint::heatmapNms() does; the goal match takes the goal labels as one
// more argument; the clause tracker is refused.

#include "models/WaypointExport.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <torch/script.h>

#include <map>
#include <numbers>

#include "ModelTestUtil.h"
#include "models/StateDict.h"
#include "support/TestPaths.h"

namespace vln::models {
namespace {

using ::testing::HasSubstr;

constexpr int64_t kViews = 6;
constexpr int64_t kSlots = 3;
constexpr int64_t kBatch = 3;

int64_t flatSize(const FeatureShape& s) { return s[0] * s[1] * s[2]; }

// a tiny policy over the encoder's features, as train::
// makeWaypointAgentModels() builds it
WaypointCmaPolicy makeWaypointPolicy(const ModelConfig& c) {
  return WaypointCmaPolicy(c, kViews,
                           c.usesRgb() ? flatSize(rgbFeatureShape(c)) : 0,
                           c.usesDepth() ? flatSize(depthFeatureShape(c)) : 0);
}

// one decision of kBatch rows: raw panoramas, candidate slots of which
// `count[b]` are real (headings on both sides of 0 and past 2 pi, so the
// view lookup wraps), the previous decision
struct Decision {
  torch::Tensor rgb, depth, candidates, mask, prev, notDone;
};

Decision randomDecision(const ModelConfig& c, const std::vector<int64_t>& count,
                        const std::vector<float>& notDone) {
  Decision d;
  d.rgb = torch::randint(0, 256, {kBatch, kViews, c.rgb_height, c.rgb_width, 3},
                         torch::kUInt8);
  d.depth = torch::rand({kBatch, kViews, c.depth_height, c.depth_width, 1});
  d.candidates = torch::stack({torch::rand({kBatch, kSlots}) * 9.0 - 3.0,
                               torch::rand({kBatch, kSlots}) * 2.75 + 0.25},
                              -1);
  d.mask = torch::zeros({kBatch, kSlots}, torch::kBool);
  for (int64_t b = 0; b < kBatch; ++b)
    d.mask[b].slice(0, 0, count[static_cast<size_t>(b)]) = true;
  d.prev = torch::stack(
      {torch::rand({kBatch}) * 6.0 - 3.0, torch::rand({kBatch}) * 3.0}, -1);
  d.notDone = torch::tensor(notDone);
  return d;
}

// three decisions: all rows start at the first, row 1 starts again at the
// third; row 2 never has a candidate, row 0 loses some
std::vector<Decision> randomEpisode(const ModelConfig& c) {
  return {randomDecision(c, {3, 1, 0}, {0, 0, 0}),
          randomDecision(c, {2, 3, 0}, {1, 1, 1}),
          randomDecision(c, {1, 2, 0}, {1, 0, 1})};
}

struct Outputs {
  std::vector<torch::Tensor> logits;
  torch::Tensor hidden;
};

// goal labels of the kBatch episodes over `features` labels, as
// world::goalLabels() gives them (model.goal_match): row 0 names labels of
// each group (1 category, 2 colour, 3 room), row 1 a room only, row 2
// nothing; undefined without the goal match
torch::Tensor goalLabelsOf(const ModelConfig& c, int64_t features) {
  if (!c.goal_match) return {};
  torch::Tensor labels = torch::zeros({kBatch, features});
  labels[0][0] = 1.0f;
  labels[0][3] = 1.0f;
  labels[0][5] = 2.0f;
  labels[0][features - 1] = 3.0f;
  labels[1][features - 2] = 3.0f;
  return labels;
}

// the arguments of forward / step_features: with model.goal_match the goal
// labels follow the instruction
std::vector<c10::IValue> scriptArguments(const torch::Tensor& rgb,
                                         const torch::Tensor& depth,
                                         const torch::Tensor& tokens,
                                         const torch::Tensor& goalLabels,
                                         const Decision& d,
                                         const torch::Tensor& hidden) {
  std::vector<c10::IValue> args = {rgb, depth, tokens};
  if (goalLabels.defined()) args.emplace_back(goalLabels);
  for (const torch::Tensor& t :
       {d.candidates, d.mask, d.prev, d.notDone, hidden})
    args.emplace_back(t);
  return args;
}

Outputs runCpp(WaypointCmaPolicyImpl& policy, ObservationEncoderImpl& encoder,
               const torch::Tensor& tokens, const torch::Tensor& goalLabels,
               const std::vector<Decision>& episode) {
  torch::NoGradGuard noGrad;
  Outputs out;
  const EncodedInstruction instruction = policy.encodeInstruction(tokens);
  torch::Tensor hidden = policy.initialHidden(kBatch);
  for (const Decision& d : episode) {
    const VisualFeatures f = encoder.forward(
        policy.config().usesRgb() ? d.rgb : torch::Tensor(),
        policy.config().usesDepth() ? d.depth : torch::Tensor());
    auto views = [](const torch::Tensor& t) {
      return t.defined() ? t.reshape({kBatch, kViews, -1}) : t;
    };
    WaypointPolicyInputs inputs{views(f.rgb), views(f.depth), d.candidates,
                                d.mask,       d.prev,         d.notDone};
    inputs.goal_labels = goalLabels;
    const WaypointPolicyOutputs o = policy.step(instruction, inputs, hidden);
    out.logits.push_back(o.logits);
    hidden = o.hidden;
  }
  out.hidden = hidden;
  return out;
}

Outputs runScript(torch::jit::Module& m, const ModelConfig& c,
                  const torch::Tensor& tokens, const torch::Tensor& goalLabels,
                  const std::vector<Decision>& episode) {
  torch::NoGradGuard noGrad;
  Outputs out;
  torch::Tensor hidden = torch::zeros({kBatch, 2, c.hidden_size});
  for (const Decision& d : episode) {
    const auto tuple = m.forward(scriptArguments(d.rgb, d.depth, tokens,
                                                 goalLabels, d, hidden))
                           .toTuple();
    out.logits.push_back(tuple->elements()[0].toTensor());
    hidden = tuple->elements()[1].toTensor();
  }
  out.hidden = hidden;
  return out;
}

// equal -inf at the same (masked) slots, close elsewhere
void expectSameLogits(const torch::Tensor& expected, const torch::Tensor& got,
                      const std::string& what) {
  ASSERT_EQ(expected.sizes(), got.sizes()) << what;
  const torch::Tensor finite = torch::isfinite(expected);
  EXPECT_TRUE(torch::equal(finite, torch::isfinite(got))) << what;
  EXPECT_TRUE(torch::allclose(expected.masked_fill(~finite, 0),
                              got.masked_fill(~finite, 0), 1e-4, 1e-5))
      << what << "\n"
      << expected << "\n"
      << got;
}

void expectClose(const Outputs& expected, const Outputs& got,
                 const std::string& what) {
  ASSERT_EQ(expected.logits.size(), got.logits.size());
  for (size_t t = 0; t < expected.logits.size(); ++t)
    expectSameLogits(expected.logits[t], got.logits[t],
                     what + " t=" + std::to_string(t));
  EXPECT_TRUE(torch::allclose(expected.hidden, got.hidden, 1e-4, 1e-5)) << what;
}

struct Variant {
  std::string name;
  ModelConfig config;
};

std::vector<Variant> variants() {
  const ModelConfig base = test::tinyConfig(PolicyType::kCma);
  std::vector<Variant> out{{"cma", base}};
  ModelConfig c = base;
  c.no_instruction = true;
  out.push_back({"no_instruction", c});
  c = base;
  c.no_rgb = true;
  out.push_back({"no_rgb", c});
  c = base;
  c.no_depth = true;
  out.push_back({"no_depth", c});
  // a unidirectional instruction encoder (model.policy: seq2seq)
  c = base;
  c.policy = PolicyType::kSeq2Seq;
  out.push_back({"seq2seq_instruction_encoder", c});
  c = base;
  c.heading_harmonics = 3;
  out.push_back({"heading_harmonics", c});
  c = base;
  c.leg_attention = true;
  out.push_back({"leg_attention", c});
  c = base;
  c.candidate_text = true;
  out.push_back({"candidate_text", c});
  // the RGB features are the semantic heads' probabilities
  c = base;
  c.rgb_semantic_outputs = 15;
  out.push_back({"rgb_semantic_outputs", c});
  // those probabilities matched with the goal's labels (model.goal_match)
  c.goal_match = true;
  out.push_back({"goal_match", c});
  return out;
}

TEST(WaypointExportTest, ExportedModuleMatchesThePolicyOnRawPanoramas) {
  for (const Variant& v : variants()) {
    SCOPED_TRACE(v.name);
    torch::manual_seed(21);
    WaypointCmaPolicy policy = makeWaypointPolicy(v.config);
    ObservationEncoder encoder(v.config);
    policy->eval();
    encoder->eval();
    const torch::Tensor tokens =
        test::randomTokens({5, 2, 7}, 8, v.config.vocab_size);
    const std::vector<Decision> episode = randomEpisode(v.config);
    const torch::Tensor goalLabels =
        goalLabelsOf(v.config, policy->rgbFeatures());

    vln::test::TempDir dir;
    exportWaypointPolicy(*policy, encoder.get(), dir / "agent.pt");
    torch::jit::Module loaded = torch::jit::load((dir / "agent.pt").string());
    const Outputs expected =
        runCpp(*policy, *encoder, tokens, goalLabels, episode);
    expectClose(expected,
                runScript(loaded, v.config, tokens, goalLabels, episode),
                v.name);
    // the logits are STOP then the K slots
    EXPECT_EQ(expected.logits[0].sizes(),
              (std::vector<int64_t>{kBatch, 1 + kSlots}));
    EXPECT_EQ(loaded.attr("model_config").toStringRef(),
              common::configToYaml(v.config));
    EXPECT_EQ(loaded.attr("num_views").toInt(), kViews);
  }
}

// a policy that reads what the archive does not compute is refused, and
// the message says which and how such a policy is scored
TEST(WaypointExportTest, RefusesTheClauseTracker) {
  ModelConfig c = test::tinyConfig(PolicyType::kCma);
  c.clause_tracker = true;
  WaypointCmaPolicy policy(c, kViews, /*rgbFeatures=*/11,
                           /*depthFeatures=*/13);
  try {
    buildWaypointExportModule(*policy, nullptr);
    ADD_FAILURE() << "clause_tracker was exported";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("model.clause_tracker"));
    EXPECT_THAT(e.what(), HasSubstr("scored from its checkpoint"));
  }
}

// with model.goal_match the archive's methods take the goal labels after
// the instruction, and the labels decide: other labels, other logits
TEST(WaypointExportTest, GoalMatchTakesTheGoalLabels) {
  torch::manual_seed(25);
  ModelConfig c = test::tinyConfig(PolicyType::kCma);
  c.rgb_semantic_outputs = 11;
  c.goal_match = true;
  // features of any size when no encoder is exported
  WaypointCmaPolicy policy(c, kViews, /*rgbFeatures=*/11, /*depthFeatures=*/13);
  policy->eval();
  torch::jit::Module m = buildWaypointExportModule(*policy, nullptr);
  const torch::Tensor tokens = test::randomTokens({4, 6, 1}, 6, c.vocab_size);
  const Decision d = randomDecision(c, {3, 0, 2}, {1, 0, 1});
  const torch::Tensor rgb = torch::rand({kBatch, kViews, 11});
  const torch::Tensor depth = torch::rand({kBatch, kViews, 13});
  const torch::Tensor hidden = torch::randn({kBatch, 2, c.hidden_size});
  const torch::Tensor labels = goalLabelsOf(c, 11);
  torch::NoGradGuard noGrad;
  auto expected = [&](const torch::Tensor& goal) {
    WaypointPolicyInputs inputs{rgb,    depth,  d.candidates,
                                d.mask, d.prev, d.notDone};
    inputs.goal_labels = goal;
    return policy->step(policy->encodeInstruction(tokens), inputs, hidden);
  };
  const WaypointPolicyOutputs named = expected(labels);
  for (const char* method : {"forward", "step_features"}) {
    const auto out = m.get_method(method)(scriptArguments(rgb, depth, tokens,
                                                          labels, d, hidden))
                         .toTuple();
    expectSameLogits(named.logits, out->elements()[0].toTensor(), method);
    EXPECT_TRUE(torch::allclose(out->elements()[1].toTensor(), named.hidden,
                                1e-4, 1e-5))
        << method;
  }
  // naming nothing moves the STOP key and the views: the archive follows
  const torch::Tensor none = torch::zeros_like(labels);
  const WaypointPolicyOutputs unnamed = expected(none);
  EXPECT_FALSE(torch::allclose(unnamed.logits.select(1, 0),
                               named.logits.select(1, 0), 1e-3, 1e-3));
  const auto out = m.get_method("step_features")(
                        scriptArguments(rgb, depth, tokens, none, d, hidden))
                       .toTuple();
  expectSameLogits(unnamed.logits, out->elements()[0].toTensor(), "unnamed");
  // without the labels the archive does not run
  EXPECT_ANY_THROW(m.get_method("step_features")(
      scriptArguments(rgb, depth, tokens, torch::Tensor(), d, hidden)));
}

TEST(WaypointExportTest, FeatureEntryPointMatchesStep) {
  torch::manual_seed(22);
  const ModelConfig c = test::tinyConfig(PolicyType::kCma);
  // features of any size when no encoder is exported
  WaypointCmaPolicy policy(c, kViews, /*rgbFeatures=*/11, /*depthFeatures=*/13);
  policy->eval();
  torch::jit::Module m = buildWaypointExportModule(*policy, nullptr);
  const torch::Tensor tokens = test::randomTokens({4, 6, 1}, 6, c.vocab_size);
  const Decision d = randomDecision(c, {3, 0, 2}, {1, 0, 1});
  const torch::Tensor rgb = torch::randn({kBatch, kViews, 11});
  const torch::Tensor depth = torch::rand({kBatch, kViews, 13});
  const torch::Tensor hidden = torch::randn({kBatch, 2, c.hidden_size});
  torch::NoGradGuard noGrad;
  const WaypointPolicyOutputs expected = policy->step(
      policy->encodeInstruction(tokens),
      {rgb, depth, d.candidates, d.mask, d.prev, d.notDone}, hidden);
  // R2R pads instructions to 200 tokens: extra PAD must not matter
  const torch::Tensor padded =
      torch::cat({tokens, torch::zeros({kBatch, 20}, torch::kInt64)}, 1);
  for (const char* method : {"forward", "step_features"}) {
    for (const torch::Tensor& t : {tokens, padded}) {
      const auto out = m.get_method(method)({rgb, depth, t, d.candidates,
                                             d.mask, d.prev, d.notDone, hidden})
                           .toTuple();
      const std::string what =
          std::string(method) + " width " + std::to_string(t.size(1));
      expectSameLogits(expected.logits, out->elements()[0].toTensor(), what);
      EXPECT_TRUE(torch::allclose(out->elements()[1].toTensor(),
                                  expected.hidden, 1e-4, 1e-5))
          << what;
    }
  }
  // a panorama without candidate slots: STOP is the only choice
  const torch::Tensor noSlots = torch::zeros({kBatch, 0, 2});
  const torch::Tensor noMask = torch::zeros({kBatch, 0}, torch::kBool);
  const WaypointPolicyOutputs stopOnly =
      policy->step(policy->encodeInstruction(tokens),
                   {rgb, depth, noSlots, noMask, d.prev, d.notDone}, hidden);
  const auto none =
      m.get_method("step_features")(
           {rgb, depth, tokens, noSlots, noMask, d.prev, d.notDone, hidden})
          .toTuple();
  expectSameLogits(stopOnly.logits, none->elements()[0].toTensor(), "no slots");
  EXPECT_EQ(none->elements()[0].toTensor().sizes(),
            (std::vector<int64_t>{kBatch, 1}));
}

TEST(WaypointExportTest, EncoderThatDoesNotFitIsRejected) {
  const ModelConfig c = test::tinyConfig(PolicyType::kCma);
  WaypointCmaPolicy policy(c, kViews, /*rgbFeatures=*/11,
                           flatSize(depthFeatureShape(c)));
  ObservationEncoder encoder(c);
  try {
    buildWaypointExportModule(*policy, encoder.get());
    ADD_FAILURE() << "11 RGB features per view cannot fit the encoder's";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("exportWaypointPolicy()"));
    EXPECT_THAT(e.what(), HasSubstr("RGB features"));
  }
  ModelConfig noRgb = c;
  noRgb.no_rgb = true;
  ObservationEncoder depthOnly(noRgb);
  WaypointCmaPolicy fits = makeWaypointPolicy(c);
  EXPECT_THROW(buildWaypointExportModule(*fits, depthOnly.get()),
               std::invalid_argument);
}

// a small predictor over `c`'s encoder features, as train::
// makeWaypointAgentModels() builds it
WaypointPredictor makeSmallPredictor(const ModelConfig& c) {
  WaypointPredictorConfig p;
  p.hidden_size = 16;
  p.heads = 2;
  p.ff_size = 24;
  p.layers = 2;
  WaypointPredictor predictor = makeWaypointPredictor(c, p, kViews);
  predictor->eval();
  return predictor;
}

TEST(WaypointExportTest, ExportedPredictorGivesThePredictorsHeatmap) {
  for (const Variant& v : variants()) {
    if (v.name == "seq2seq_instruction_encoder") continue;
    SCOPED_TRACE(v.name);
    torch::manual_seed(24);
    WaypointCmaPolicy policy = makeWaypointPolicy(v.config);
    ObservationEncoder encoder(v.config);
    WaypointPredictor predictor = makeSmallPredictor(v.config);
    policy->eval();
    encoder->eval();
    ExportedPredictor exported{predictor.get(), 4, 7, 5, 0.0};
    torch::jit::Module m =
        buildWaypointExportModule(*policy, encoder.get(), exported);
    EXPECT_TRUE(m.attr("has_predictor").toBool());
    EXPECT_EQ(m.attr("max_candidates").toInt(), 4);

    const Decision d = randomDecision(v.config, {0, 0, 0}, {0, 0, 0});
    torch::NoGradGuard noGrad;
    const VisualFeatures f = encoder->forward(
        v.config.usesRgb() ? d.rgb : torch::Tensor(),
        v.config.usesDepth() ? d.depth : torch::Tensor());
    auto views = [](const torch::Tensor& t) {
      return t.defined() ? t.reshape({kBatch, kViews, -1}) : torch::zeros({1});
    };
    const torch::Tensor expected = waypointProbabilities(
        predictor->forward(f.depth.defined() ? views(f.depth) : torch::Tensor(),
                           f.rgb.defined() ? views(f.rgb) : torch::Tensor()));
    const torch::Tensor heatmap =
        m.run_method("heatmap_features", views(f.rgb), views(f.depth))
            .toTensor();
    ASSERT_EQ(heatmap.sizes(), (std::vector<int64_t>{kBatch, 120, 12}));
    EXPECT_TRUE(torch::allclose(heatmap, expected, 1e-5, 1e-7));

    // propose() on the raw panorama: the suppression of that heatmap
    const auto raw = m.run_method("propose", d.rgb, d.depth).toTuple();
    const auto fromHeatmap = m.run_method("suppress", heatmap).toTuple();
    for (size_t i : {0u, 1u})
      EXPECT_TRUE(torch::equal(raw->elements()[i].toTensor(),
                               fromHeatmap->elements()[i].toTensor()));
    const torch::Tensor mask = raw->elements()[1].toTensor();
    ASSERT_EQ(mask.sizes(), (std::vector<int64_t>{kBatch, 4}));
    // a softmax is positive everywhere: the first slot is always filled
    EXPECT_TRUE(mask.select(1, 0).all().item<bool>());
  }
}

// the suppression on a hand-made heatmap, worked out by hand from
// waypoint::heatmapNms()'s rule (highest cell, its box of +-7 headings
// (circular) x +-5 distances goes, one candidate per heading bin)
TEST(WaypointExportTest, ExportedSuppressionFollowsHeatmapNms) {
  const ModelConfig c = test::tinyConfig(PolicyType::kCma);
  WaypointCmaPolicy policy = makeWaypointPolicy(c);
  WaypointPredictor predictor = makeSmallPredictor(c);
  torch::jit::Module m = buildWaypointExportModule(
      *policy, nullptr, ExportedPredictor{predictor.get(), 5, 7, 5, 0.0});
  torch::Tensor heatmap = torch::zeros({2, 120, 12});
  heatmap[0][0][3] = 0.5f;     // the first pick: 0 degrees, 1.0 m
  heatmap[0][115][3] = 0.45f;  // 5 bins clockwise of it: inside its box
  heatmap[0][60][11] = 0.3f;   // second: 180 degrees, 3.0 m
  heatmap[0][60][0] = 0.2f;    // outside that box, but its heading is taken
  heatmap[0][30][5] = 0.1f;    // third: 90 degrees, 1.5 m
  // row 1 is all zeros: nothing above min_score 0
  const auto out = m.run_method("suppress", heatmap).toTuple();
  const torch::Tensor slots = out->elements()[0].toTensor();
  const torch::Tensor mask = out->elements()[1].toTensor();
  const float step = 2.0f * std::numbers::pi_v<float> / 120.0f;
  EXPECT_TRUE(torch::equal(
      mask, torch::tensor({1, 1, 1, 0, 0, 0, 0, 0, 0, 0}, torch::kBool)
                .view({2, 5})));
  EXPECT_FLOAT_EQ(slots[0][0][0].item<float>(), 0.0f);
  EXPECT_FLOAT_EQ(slots[0][0][1].item<float>(), 1.0f);
  EXPECT_FLOAT_EQ(slots[0][1][0].item<float>(), 60.0f * step);
  EXPECT_FLOAT_EQ(slots[0][1][1].item<float>(), 3.0f);
  EXPECT_FLOAT_EQ(slots[0][2][0].item<float>(), 30.0f * step);
  EXPECT_FLOAT_EQ(slots[0][2][1].item<float>(), 1.5f);
  EXPECT_TRUE(torch::equal(slots[1], torch::zeros({5, 2})));
}

TEST(WaypointExportTest, PredictorThatDoesNotFitIsRejected) {
  const ModelConfig c = test::tinyConfig(PolicyType::kCma);
  WaypointCmaPolicy policy = makeWaypointPolicy(c);
  WaypointPredictorConfig p;
  p.hidden_size = 16;
  p.heads = 2;
  WaypointPredictor twelveViews = makeWaypointPredictor(c, p, 12);
  try {
    buildWaypointExportModule(*policy, nullptr,
                              ExportedPredictor{twelveViews.get()});
    ADD_FAILURE() << "a predictor of 12 views cannot serve 6";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("exportWaypointPolicy()"));
    EXPECT_THAT(e.what(), HasSubstr("views"));
  }
  WaypointPredictor fits = makeSmallPredictor(c);
  EXPECT_THROW(buildWaypointExportModule(*policy, nullptr,
                                         ExportedPredictor{fits.get(), -1}),
               std::invalid_argument);
  // a predictor of the depth features the policy does not read
  ModelConfig noDepth = c;
  noDepth.no_depth = true;
  WaypointCmaPolicy rgbOnly = makeWaypointPolicy(noDepth);
  EXPECT_THROW(buildWaypointExportModule(*rgbOnly, nullptr,
                                         ExportedPredictor{fits.get()}),
               std::invalid_argument);
}

// Python's torch.jit.load runs the archive on a raw panorama and reproduces
// the C++ outputs (with model.goal_match too, the goal labels passed after
// the instruction); tensors travel both ways as TorchScript tensor archives
TEST(WaypointExportTest, PythonTorchJitLoadReproducesOutputs) {
  if (vln::test::runCommand("/usr/bin/python3 -c 'import torch'") != 0)
    GTEST_SKIP() << "/usr/bin/python3 cannot import torch";
  const std::string script = R"PY(
import sys, torch
agent = torch.jit.load(sys.argv[1])
x = dict(torch.jit.load(sys.argv[2]).named_buffers())
goal = [x["goal_labels"]] if "goal_labels" in x else []
with torch.no_grad():
    logits, hidden = agent(x["rgb"], x["depth"], x["instruction"], *goal,
                           x["candidates"], x["candidate_mask"], x["prev"],
                           x["not_done"], x["hidden"])
    candidates, candidate_mask = agent.propose(x["rgb"], x["depth"])
class Out(torch.nn.Module):
    pass
out = Out()
out.register_buffer("logits", logits)
out.register_buffer("hidden", hidden)
out.register_buffer("candidates", candidates)
out.register_buffer("candidate_mask", candidate_mask)
torch.jit.script(out).save(sys.argv[3])
)PY";
  ModelConfig goalMatch = test::tinyConfig(PolicyType::kCma);
  goalMatch.rgb_semantic_outputs = 15;
  goalMatch.goal_match = true;
  for (const Variant& v : {Variant{"cma", test::tinyConfig(PolicyType::kCma)},
                           Variant{"goal_match", goalMatch}}) {
    SCOPED_TRACE(v.name);
    const ModelConfig& c = v.config;
    torch::manual_seed(23);
    WaypointCmaPolicy policy = makeWaypointPolicy(c);
    ObservationEncoder encoder(c);
    policy->eval();
    const torch::Tensor tokens = test::randomTokens({3, 5, 2}, 6, c.vocab_size);
    const Decision d = randomDecision(c, {1, 3, 0}, {1, 0, 1});
    const torch::Tensor hidden = torch::randn({kBatch, 2, c.hidden_size});
    const torch::Tensor goalLabels = goalLabelsOf(c, policy->rgbFeatures());
    vln::test::TempDir dir;
    WaypointPredictor predictor = makeSmallPredictor(c);
    exportWaypointPolicy(*policy, encoder.get(), dir / "agent.pt",
                         ExportedPredictor{predictor.get()});
    NamedTensors inputs = {{"rgb", d.rgb},
                           {"depth", d.depth},
                           {"instruction", tokens},
                           {"candidates", d.candidates},
                           {"candidate_mask", d.mask},
                           {"prev", d.prev},
                           {"not_done", d.notDone},
                           {"hidden", hidden}};
    if (goalLabels.defined()) inputs.emplace_back("goal_labels", goalLabels);
    writeTensorFile(dir / "inputs.pt", inputs);
    vln::test::writeText(dir / "run.py", script);
    std::string log;
    ASSERT_EQ(
        vln::test::runCommand("/usr/bin/python3 " + (dir / "run.py").string() +
                                  " " + (dir / "agent.pt").string() + " " +
                                  (dir / "inputs.pt").string() + " " +
                                  (dir / "outputs.pt").string() + " 2>&1",
                              &log),
        0)
        << log;
    std::map<std::string, torch::Tensor> py;
    for (auto& [name, t] : readTensorFile(dir / "outputs.pt")) py[name] = t;

    torch::NoGradGuard noGrad;
    const VisualFeatures f = encoder->forward(d.rgb, d.depth);
    WaypointPolicyInputs in{f.rgb.reshape({kBatch, kViews, -1}),
                            f.depth.reshape({kBatch, kViews, -1}),
                            d.candidates,
                            d.mask,
                            d.prev,
                            d.notDone};
    in.goal_labels = goalLabels;
    const WaypointPolicyOutputs expected =
        policy->step(policy->encodeInstruction(tokens), in, hidden);
    expectSameLogits(expected.logits, py.at("logits"), "python");
    EXPECT_TRUE(torch::allclose(py.at("hidden"), expected.hidden, 1e-4, 1e-5));
    // the candidates Python gets are the ones C++ gets from the same archive
    torch::jit::Module loaded = torch::jit::load((dir / "agent.pt").string());
    const auto proposed =
        loaded.run_method("propose", d.rgb, d.depth).toTuple();
    EXPECT_TRUE(
        torch::equal(py.at("candidates"), proposed->elements()[0].toTensor()));
    EXPECT_TRUE(torch::equal(py.at("candidate_mask"),
                             proposed->elements()[1].toTensor()));
  }
}

}  // namespace
}  // namespace vln::models
