// The exported TorchScript agent reproduces the C++ modules, loaded by
// torch::jit::load here and by Python's torch.jit.load when available.
#include "models/Export.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <torch/script.h>

#include "ModelTestUtil.h"
#include "models/StateDict.h"
#include "support/TestPaths.h"

namespace vln::models {
namespace {

using test::randomTokens;
using test::tinyConfig;

struct StepData {
  torch::Tensor rgb, depth, prevAction, notDone;
};

// a short rollout for batch 2: row 1 starts a new episode at step 2
std::vector<StepData> rollout(const ModelConfig& c, int64_t steps) {
  std::vector<StepData> out;
  for (int64_t t = 0; t < steps; ++t) {
    StepData s;
    s.rgb = torch::randint(0, 256, {2, c.rgb_height, c.rgb_width, 3},
                           torch::kUInt8);
    s.depth = torch::rand({2, c.depth_height, c.depth_width, 1});
    s.prevAction = torch::randint(0, kNumActions, {2}, torch::kInt64);
    s.notDone = torch::ones({2});
    if (t == 0) s.notDone.zero_();
    if (t == 2) s.notDone[1] = 0;
    out.push_back(s);
  }
  return out;
}

struct Outputs {
  std::vector<torch::Tensor> logits, progress;
  torch::Tensor hidden;
};

Outputs runCpp(PolicyImpl& policy, ObservationEncoderImpl& encoder,
               const torch::Tensor& tokens, const std::vector<StepData>& data) {
  torch::NoGradGuard g;
  Outputs out;
  const EncodedInstruction instr = policy.encodeInstruction(tokens);
  torch::Tensor h = policy.initialHidden(2);
  for (const auto& s : data) {
    const VisualFeatures f = encoder.forward(s.rgb, s.depth);
    const auto o =
        policy.step(instr, {f.rgb, f.depth, s.prevAction, s.notDone}, h);
    out.logits.push_back(o.logits);
    out.progress.push_back(o.progress.defined() ? o.progress
                                                : torch::zeros({2}));
    h = o.hidden;
  }
  out.hidden = h;
  return out;
}

Outputs runScript(torch::jit::Module& m, const ModelConfig& c,
                  const torch::Tensor& tokens,
                  const std::vector<StepData>& data) {
  torch::NoGradGuard g;
  Outputs out;
  torch::Tensor h = torch::zeros({2, c.recurrentStateRows(), c.hidden_size});
  for (const auto& s : data) {
    const auto tuple =
        m.forward({s.rgb, s.depth, tokens, s.prevAction, s.notDone, h})
            .toTuple();
    out.logits.push_back(tuple->elements()[0].toTensor());
    out.progress.push_back(tuple->elements()[1].toTensor());
    h = tuple->elements()[2].toTensor();
  }
  out.hidden = h;
  return out;
}

void expectClose(const Outputs& a, const Outputs& b, const std::string& what) {
  ASSERT_EQ(a.logits.size(), b.logits.size());
  for (size_t t = 0; t < a.logits.size(); ++t) {
    EXPECT_TRUE(torch::allclose(a.logits[t], b.logits[t], 1e-4, 1e-5))
        << what << " logits t=" << t << "\n"
        << a.logits[t] << "\n"
        << b.logits[t];
    EXPECT_TRUE(torch::allclose(a.progress[t], b.progress[t], 1e-4, 1e-5))
        << what << " progress t=" << t;
  }
  EXPECT_TRUE(torch::allclose(a.hidden, b.hidden, 1e-4, 1e-5)) << what;
}

struct Variant {
  std::string name;
  ModelConfig config;
};

std::vector<Variant> variants() {
  std::vector<Variant> out;
  for (PolicyType p : {PolicyType::kSeq2Seq, PolicyType::kCma}) {
    const std::string base = policyName(p);
    out.push_back({base, tinyConfig(p)});
    ModelConfig c = tinyConfig(p);
    c.no_rgb = true;
    c.progress_monitor = false;
    out.push_back({base + "_no_rgb", c});
    c = tinyConfig(p);
    c.no_instruction = true;
    c.seq2seq_prev_action = true;
    out.push_back({base + "_no_instruction", c});
    c = tinyConfig(p);
    c.no_depth = true;
    out.push_back({base + "_no_depth", c});
  }
  // the turn count carried in the state's third row
  ModelConfig turns = tinyConfig(PolicyType::kCma);
  turns.turn_count_embedding_dim = 8;
  out.push_back({"cma_turn_count", turns});
  // a deeper small RGB CNN (model.rgb_cnn_channels, rgb_cnn_strides)
  ModelConfig deeper = tinyConfig(PolicyType::kCma);
  deeper.rgb_cnn_channels = {8, 8, 12, 16};
  deeper.rgb_cnn_strides = {2, 1, 2, 2};
  out.push_back({"cma_deeper_small_cnn", deeper});
  // the ResNet emitters (BatchNorm and GroupNorm paths) on 64 px images
  ModelConfig r = tinyConfig(PolicyType::kCma);
  r.rgb_encoder = EncoderType::kResNet18;
  r.depth_encoder = EncoderType::kResNet18;
  r.rgb_height = r.rgb_width = 64;
  r.depth_height = r.depth_width = 64;
  out.push_back({"cma_resnet18", r});
  // VLN-CE's RGB input: pixels / 255 without the ImageNet normalisation
  r.normalize_rgb = false;
  out.push_back({"cma_resnet18_pixels_over_255", r});
  return out;
}

TEST(ExportTest, ExportedModuleMatchesCppModulesOnRawObservations) {
  for (const auto& v : variants()) {
    SCOPED_TRACE(v.name);
    torch::manual_seed(11);
    auto policy = makePolicy(v.config);
    ObservationEncoder encoder(v.config);
    policy->eval();
    encoder->eval();
    // non-trivial BatchNorm statistics, so that the export must carry them
    {
      torch::NoGradGuard g;
      for (auto& item : encoder->named_buffers())
        if (item.key().find("running_") != std::string::npos)
          item.value().uniform_(0.5, 1.5);
    }
    const torch::Tensor tokens = randomTokens({5, 3}, 7, v.config.vocab_size);
    const auto data = rollout(v.config, 4);

    vln::test::TempDir dir;
    exportPolicy(*policy, encoder.get(), dir / "agent.pt");
    torch::jit::Module loaded = torch::jit::load((dir / "agent.pt").string());
    expectClose(runCpp(*policy, *encoder, tokens, data),
                runScript(loaded, v.config, tokens, data), v.name);
    EXPECT_EQ(loaded.attr("model_config").toStringRef(),
              common::configToYaml(v.config));
  }
}

TEST(ExportTest, FeatureEntryPointMatchesPolicy) {
  torch::manual_seed(12);
  const ModelConfig c = tinyConfig(PolicyType::kCma);
  auto policy = makePolicy(c);
  torch::jit::Module m = buildExportModule(*policy, nullptr);
  const PolicyInputs in = test::randomInputs(c, 1, 2);
  const torch::Tensor tokens = randomTokens({4, 6}, 6, c.vocab_size);
  const torch::Tensor h = torch::randn({2, 2, c.hidden_size});
  torch::NoGradGuard g;
  const auto expected =
      policy->step(policy->encodeInstruction(tokens), test::stepOf(in, 0), h);
  // R2R pads instructions to 200 tokens: extra PAD must not matter
  const torch::Tensor padded =
      torch::cat({tokens, torch::zeros({2, 20}, torch::kInt64)}, 1);
  for (const char* method : {"forward", "step_features"}) {
    for (const torch::Tensor& t : {tokens, padded}) {
      const auto out =
          m.get_method(method)({in.rgb[0], in.depth[0], t, in.prev_actions[0],
                                in.not_done[0], h})
              .toTuple();
      EXPECT_TRUE(torch::allclose(out->elements()[0].toTensor(),
                                  expected.logits, 1e-4, 1e-5))
          << method << " width " << t.size(1);
      EXPECT_TRUE(torch::allclose(out->elements()[2].toTensor(),
                                  expected.hidden, 1e-4, 1e-5))
          << method << " width " << t.size(1);
    }
  }
}

TEST(ExportTest, RxrTextFeaturesAndSixActionsRoundTrip) {
  // model.num_actions 6 and model.instruction_features: rxr_text export:
  // six logits, the previous LOOK actions embedded, features padded to
  // RxR's 512 rows give the C++ policy's outputs
  for (PolicyType type : {PolicyType::kSeq2Seq, PolicyType::kCma}) {
    torch::manual_seed(13);
    const ModelConfig c = test::tinyRxrConfig(type);
    auto policy = makePolicy(c);
    torch::jit::Module m = buildExportModule(*policy, nullptr);
    PolicyInputs in = test::randomInputs(c, 1, 2);
    in.prev_actions[0] = torch::tensor({4, 5}, torch::kInt64);
    in.not_done[0].fill_(1);
    const torch::Tensor features = test::randomTextFeatures({4, 6}, 6, 8);
    const torch::Tensor h =
        torch::randn({2, c.recurrentStateRows(), c.hidden_size});
    torch::NoGradGuard g;
    const auto expected = policy->step(policy->encodeInstruction(features),
                                       test::stepOf(in, 0), h);
    ASSERT_EQ(expected.logits.sizes(), (std::vector<int64_t>{2, 6}));
    const torch::Tensor padded =
        torch::cat({features, torch::zeros({2, 506, 8})}, 1);
    for (const torch::Tensor& t : {features, padded}) {
      const auto out =
          m.get_method("step_features")({in.rgb[0], in.depth[0], t,
                                         in.prev_actions[0], in.not_done[0], h})
              .toTuple();
      EXPECT_TRUE(torch::allclose(out->elements()[0].toTensor(),
                                  expected.logits, 1e-4, 1e-5))
          << policyName(type) << " width " << t.size(1);
      EXPECT_TRUE(torch::allclose(out->elements()[2].toTensor(),
                                  expected.hidden, 1e-4, 1e-5))
          << policyName(type) << " width " << t.size(1);
    }
    // the archive's config names both options
    const ModelConfig stored = common::loadConfigText<ModelConfig>(
        m.attr("model_config").toStringRef());
    EXPECT_EQ(stored, c);
  }
}

TEST(ExportTest, MismatchedEncoderIsRejected) {
  ModelConfig c = tinyConfig(PolicyType::kSeq2Seq);
  auto policy = makePolicy(c);
  c.no_rgb = true;
  ObservationEncoder encoder(c);
  EXPECT_THROW(buildExportModule(*policy, encoder.get()),
               std::invalid_argument);
}

// Python's torch.jit.load runs the files and reproduces the C++ outputs;
// tensors travel both ways as TorchScript tensor archives. One Python
// process handles both policies (its start-up dominates the test's time).
TEST(ExportTest, PythonTorchJitLoadReproducesOutputs) {
  if (vln::test::runCommand("/usr/bin/python3 -c 'import torch'") != 0)
    GTEST_SKIP() << "/usr/bin/python3 cannot import torch";
  vln::test::TempDir dir;
  std::string args;
  std::vector<PolicyOutputs> expected;
  for (PolicyType p : {PolicyType::kSeq2Seq, PolicyType::kCma}) {
    torch::manual_seed(13);
    const ModelConfig c = tinyConfig(p);
    auto policy = makePolicy(c);
    ObservationEncoder encoder(c);
    policy->eval();
    const torch::Tensor tokens = randomTokens({3, 5}, 6, c.vocab_size);
    const auto data = rollout(c, 1);
    const torch::Tensor h =
        torch::randn({2, c.recurrentStateRows(), c.hidden_size});
    const torch::Tensor notDone = torch::ones({2});
    const std::string name = policyName(p);
    exportPolicy(*policy, encoder.get(), dir / (name + "_agent.pt"));
    writeTensorFile(dir / (name + "_inputs.pt"),
                    {{"rgb", data[0].rgb},
                     {"depth", data[0].depth},
                     {"instruction", tokens},
                     {"prev_action", data[0].prevAction},
                     {"not_done", notDone},
                     {"hidden", h}});
    for (const char* file : {"_agent.pt ", "_inputs.pt ", "_outputs.pt "})
      args += (dir / (name + file)).string();
    torch::NoGradGuard g;
    const VisualFeatures f = encoder->forward(data[0].rgb, data[0].depth);
    expected.push_back(
        policy->step(policy->encodeInstruction(tokens),
                     {f.rgb, f.depth, data[0].prevAction, notDone}, h));
  }
  const std::string script = R"PY(
import sys, torch
class Out(torch.nn.Module):
    pass
for i in range(1, len(sys.argv), 3):
    agent = torch.jit.load(sys.argv[i])
    x = dict(torch.jit.load(sys.argv[i + 1]).named_buffers())
    with torch.no_grad():
        logits, progress, hidden = agent(x["rgb"], x["depth"],
                                         x["instruction"], x["prev_action"],
                                         x["not_done"], x["hidden"])
    out = Out()
    out.register_buffer("logits", logits)
    out.register_buffer("progress", progress)
    out.register_buffer("hidden", hidden)
    torch.jit.script(out).save(sys.argv[i + 2])
)PY";
  vln::test::writeText(dir / "run.py", script);
  std::string log;
  ASSERT_EQ(
      vln::test::runCommand(
          "/usr/bin/python3 " + (dir / "run.py").string() + " " + args, &log),
      0)
      << log;

  size_t k = 0;
  for (PolicyType p : {PolicyType::kSeq2Seq, PolicyType::kCma}) {
    SCOPED_TRACE(policyName(p));
    std::map<std::string, torch::Tensor> py;
    for (auto& [name, t] :
         readTensorFile(dir / (std::string(policyName(p)) + "_outputs.pt")))
      py[name] = t;
    const PolicyOutputs& e = expected[k++];
    EXPECT_TRUE(torch::allclose(py.at("logits"), e.logits, 1e-4, 1e-5));
    EXPECT_TRUE(torch::allclose(py.at("progress"), e.progress, 1e-4, 1e-5));
    EXPECT_TRUE(torch::allclose(py.at("hidden"), e.hidden, 1e-4, 1e-5));
  }
}

}  // namespace
}  // namespace vln::models
