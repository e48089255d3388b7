// scripts/convert_vlnce_checkpoint.py turns VLN-CE's CMAPolicy and
// Seq2SeqPolicy checkpoints into what `eval --checkpoint` reads. The
// checkpoints are synthesised by tests/eval/vlnce_reference.py, which
// rebuilds VLN-CE's networks from torch.nn layers with VLN-CE's module tree
// (so their state_dict has VLN-CE's key layout and shapes, 2020 and 2021),
// pickles a stand-in of habitat's Config beside the random weights, and runs
// a transcription of VLN-CE's forward, one step at a time, on random
// observations. Here every converted tensor must equal its source, the C++
// encoders and policy must give VLN-CE's logits on the same observations,
// bad checkpoints must be refused with the file and the key named, and the
// eval binary must score a converted policy exactly as it scores the same
// policy in our own format. Skipped when /usr/bin/python3 lacks torch.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <torch/torch.h>

#include <cstdio>
#include <map>
#include <set>

#include "models/ObservationEncoder.h"
#include "models/Policy.h"
#include "models/StateDict.h"
#include "rollout/Metrics.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"
#include "train/Checkpoint.h"
#include "train/ExperimentConfig.h"
#include "train/TinyWorldBinaryTest.h"

namespace vln::eval {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

bool havePythonTorch() {
  static const bool have =
      vln::test::runCommand("/usr/bin/python3 -c 'import torch' 2>&1") == 0;
  return have;
}

fs::path helperScript() {
  return vln::test::sourcePath() / "tests" / "eval" / "vlnce_reference.py";
}

fs::path converterScript() {
  return vln::test::sourcePath() / "scripts" / "convert_vlnce_checkpoint.py";
}

// runs a Python script; returns its exit status, output in `log`
int python(const fs::path& script, const std::string& args, std::string* log) {
  return vln::test::runCommand(
      "/usr/bin/python3 " + script.string() + " " + args + " 2>&1", log);
}

std::map<std::string, torch::Tensor> tensorMap(const fs::path& file) {
  std::map<std::string, torch::Tensor> out;
  for (auto& [name, tensor] : models::readTensorFile(file)) out[name] = tensor;
  return out;
}

// ---------------------------------------------------------------------------
// the key mapping, stated independently of the converter

// the VLN-CE state_dict key of one of our policy tensors
std::string vlnceKeyOfPolicy(const std::string& ours, bool cma,
                             const std::string& layout) {
  const auto dot = ours.rfind('.');
  const std::string module = ours.substr(0, dot);
  const std::string leaf = ours.substr(dot + 1);
  static const std::map<std::string, std::string> common = {
      {"instruction_encoder.embedding",
       "net.instruction_encoder.embedding_layer"},
      {"instruction_encoder.lstm", "net.instruction_encoder.encoder_rnn"},
      {"state_encoder.gru", "net.state_encoder.rnn"},
      {"second_state_encoder.gru", "net.second_state_encoder.rnn"},
      {"action_head", "action_distribution.linear"},
      {"rgb_spatial_embedding", "net.rgb_encoder.spatial_embeddings"},
      {"depth_spatial_embedding", "net.depth_encoder.spatial_embeddings"},
      {"second_state_compress", "net.second_state_compress.0"}};
  if (auto it = common.find(module); it != common.end())
    return it->second + "." + leaf;
  if (module == "rgb_linear")
    return (cma                ? "net.rgb_linear.2"
            : layout == "2020" ? "net.rgb_encoder.fc"
                               : "net.rgb_encoder.fc.1") +
           ("." + leaf);
  if (module == "depth_linear")
    return (cma ? "net.depth_linear.1" : "net.depth_encoder.visual_fc.1") +
           ("." + leaf);
  return "net." + ours;  // state_q, text_k, rgb_kv, progress_monitor, ...
}

// the VLN-CE key of one of our RGB encoder tensors (torchvision names)
std::string vlnceKeyOfRgb(const std::string& ours, const std::string& layout) {
  if (layout == "2020") return "net.rgb_encoder.cnn." + ours;
  static const std::map<std::string, std::string> sequential = {
      {"conv1", "0"},  {"bn1", "1"},    {"layer1", "4"},
      {"layer2", "5"}, {"layer3", "6"}, {"layer4", "7"}};
  const auto dot = ours.find('.');
  return "net.rgb_encoder.cnn." + sequential.at(ours.substr(0, dot)) +
         ours.substr(dot);
}

// ---------------------------------------------------------------------------

class ConvertVlnceCheckpointTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!havePythonTorch()) GTEST_SKIP() << "/usr/bin/python3 lacks torch";
  }

  // vlnce_reference.py make <dir/name> <args>; returns the directory
  fs::path make(const std::string& name, const std::string& args) {
    const fs::path out = dir_ / name;
    std::string log;
    EXPECT_EQ(python(helperScript(), "make " + out.string() + " " + args, &log),
              0)
        << log;
    return out;
  }

  // the converter on <source>/vlnce.pth into <source>/out
  int convert(const fs::path& source, const std::string& args,
              std::string* log) {
    return python(converterScript(),
                  (source / "vlnce.pth").string() + " --out-dir " +
                      (source / "out").string() + " " + args,
                  log);
  }

  // every converted tensor equals its source tensor, and every source
  // tensor is converted except those VLN-CE keeps but never uses
  void expectExactRoundTrip(const fs::path& source, bool cma,
                            const std::string& layout,
                            const std::set<std::string>& dropped) {
    auto vlnce = tensorMap(source / "source.pt");
    std::set<std::string> used;
    auto expectEqual = [&](const std::string& key, torch::Tensor ours) {
      ASSERT_TRUE(vlnce.count(key)) << key << " is not a VLN-CE tensor";
      used.insert(key);
      torch::Tensor theirs = vlnce.at(key);
      // kernel-1 Conv1d weights [out, in, 1] are our Linear weights
      if (theirs.dim() == 3 && ours.dim() == 2) theirs = theirs.squeeze(2);
      EXPECT_TRUE(torch::equal(ours, theirs)) << key;
    };
    const fs::path out = source / "out";
    for (const auto& [name, tensor] :
         train::loadCheckpoint(out / "ckpt.0.pth").policy)
      expectEqual(vlnceKeyOfPolicy(name, cma, layout), tensor);
    for (const auto& [name, tensor] :
         models::readTensorFile(out / "rgb_encoder.pt"))
      expectEqual(vlnceKeyOfRgb(name, layout), tensor);
    for (const auto& [name, tensor] :
         models::readTensorFile(out / "depth_encoder.pt"))
      expectEqual("net.depth_encoder.visual_encoder." + name, tensor);
    std::set<std::string> left;
    for (const auto& [key, tensor] : vlnce)
      if (!used.count(key)) left.insert(key);
    EXPECT_EQ(left, dropped);
  }

  // the converted run config, policy and encoders on VLN-CE's recorded
  // observations; returns max |logits - VLN-CE's logits|
  double maxLogitError(const fs::path& source,
                       train::ExperimentConfig* configOut = nullptr) {
    const fs::path out = source / "out";
    const train::ExperimentConfig config =
        train::loadExperimentConfig(out / "config.yaml");
    if (configOut != nullptr) *configOut = config;
    auto policy = models::makePolicy(config.model);
    models::ObservationEncoder encoder(config.model);
    encoder->loadPretrained();
    const fs::path ckpt = out / "ckpt.0.pth";
    models::loadStateStrict(*policy, train::loadCheckpoint(ckpt).policy,
                            ckpt.string());
    policy->eval();
    encoder->eval();
    torch::NoGradGuard noGrad;
    auto io = tensorMap(source / "io.pt");
    const models::VisualFeatures features =
        encoder->forward(io.at("rgb"), io.at("depth"));
    const models::PolicyInputs inputs{features.rgb, features.depth,
                                      io.at("prev_actions"), io.at("not_done")};
    const torch::Tensor& tokens = io.at("tokens");
    const models::PolicyOutputs outputs =
        policy->forwardSequence(policy->encodeInstruction(tokens), inputs,
                                policy->initialHidden(tokens.size(0)));
    const torch::Tensor& expected = io.at("logits");
    EXPECT_EQ(outputs.logits.sizes(), expected.sizes());
    // the logits must vary, or the comparison says little
    EXPECT_GT(expected.std().item<double>(), 0.1);
    const double error = (outputs.logits - expected).abs().max().item<double>();
    char text[32];
    std::snprintf(text, sizeof(text), "%.3g", error);
    RecordProperty("max_logit_error", text);
    return error;
  }

  vln::test::TempDir dir_;
};

TEST_F(ConvertVlnceCheckpointTest, CmaWithProgressMonitor2021LayoutIsExact) {
  const fs::path source = make("cma_pm", "--policy cma --pm");
  std::string log;
  ASSERT_EQ(convert(source, "", &log), 0) << log;
  EXPECT_THAT(log, HasSubstr("VLN-CE 2021 layout, cma"));
  expectExactRoundTrip(source, /*cma=*/true, "2021", {"net._scale"});
  train::ExperimentConfig config;
  EXPECT_LT(maxLogitError(source, &config), 1e-5);
  EXPECT_EQ(config.model.policy, models::PolicyType::kCma);
  EXPECT_TRUE(config.model.progress_monitor);
  EXPECT_FALSE(config.model.normalize_rgb);
  EXPECT_EQ(config.model.rgb_encoder, models::EncoderType::kResNet18);
  EXPECT_EQ(config.model.depth_resnet_base_planes, 8);
  EXPECT_EQ(config.model.hidden_size, 16);
  EXPECT_EQ(config.model.instruction_hidden_size, 6);
  EXPECT_EQ(config.model.rgb_projection_size, 8);
  EXPECT_EQ(config.model.depth_projection_size, 6);
  EXPECT_EQ(config.model.prev_action_embedding_dim, 32);
  EXPECT_EQ(config.model.spatial_embedding_dim, 64);
  EXPECT_EQ(config.sim.depth.camera.width, 64);
  EXPECT_EQ(config.task.max_episode_steps, 500);
}

TEST_F(ConvertVlnceCheckpointTest, CmaWithoutProgressMonitor2020LayoutIsExact) {
  // the 2020 release: ResNet-50 under torchvision's names, the critic head;
  // in the legacy (pre-zip) file format of the torch it was trained with
  const fs::path source =
      make("cma_2020", "--policy cma --layout 2020 --legacy-format");
  std::string log;
  ASSERT_EQ(convert(source, "", &log), 0) << log;
  EXPECT_THAT(log, HasSubstr("VLN-CE 2020 layout, cma"));
  EXPECT_THAT(log, HasSubstr("dropped net.progress_monitor"));
  expectExactRoundTrip(
      source, /*cma=*/true, "2020",
      {"net._scale", "net.progress_monitor.weight", "net.progress_monitor.bias",
       "critic.fc.weight", "critic.fc.bias"});
  train::ExperimentConfig config;
  EXPECT_LT(maxLogitError(source, &config), 1e-5);
  EXPECT_FALSE(config.model.progress_monitor);
  EXPECT_EQ(config.model.rgb_encoder, models::EncoderType::kResNet50);
}

TEST_F(ConvertVlnceCheckpointTest, Seq2SeqWithPrevActionAndImageNetRgbIsExact) {
  // 32x32 RGB gives a 1x1 ResNet map: averaging its 4x4 pooling is exact
  const fs::path source =
      make("seq2seq", "--policy seq2seq --pm --prev-action --normalize-rgb");
  std::string log;
  ASSERT_EQ(convert(source, "", &log), 0) << log;
  EXPECT_THAT(log, Not(HasSubstr("approximation")));
  expectExactRoundTrip(source, /*cma=*/false, "2021", {});
  train::ExperimentConfig config;
  EXPECT_LT(maxLogitError(source, &config), 1e-5);
  EXPECT_EQ(config.model.policy, models::PolicyType::kSeq2Seq);
  EXPECT_TRUE(config.model.seq2seq_prev_action);
  EXPECT_TRUE(config.model.normalize_rgb);
}

TEST_F(ConvertVlnceCheckpointTest, Seq2Seq2020LayoutIsExact) {
  // Seq2Seq_DA's layout: the whole torchvision ResNet-50 (ImageNet
  // classifier too), the RGB projection at net.rgb_encoder.fc
  const fs::path source =
      make("seq2seq_2020", "--policy seq2seq --layout 2020");
  std::string log;
  ASSERT_EQ(convert(source, "", &log), 0) << log;
  expectExactRoundTrip(
      source, /*cma=*/false, "2020",
      {"net.progress_monitor.weight", "net.progress_monitor.bias",
       "critic.fc.weight", "critic.fc.bias", "net.rgb_encoder.cnn.fc.weight",
       "net.rgb_encoder.cnn.fc.bias"});
  EXPECT_LT(maxLogitError(source), 1e-5);
}

TEST_F(ConvertVlnceCheckpointTest, Seq2SeqRgbPoolingAt224NeedsTheFlag) {
  // a 224x224 image gives a 7x7 map, which 4x4 cells cover unevenly
  const fs::path source =
      make("seq2seq_224", "--policy seq2seq --rgb-size 224 --steps 2");
  std::string log;
  EXPECT_NE(convert(source, "", &log), 0);
  EXPECT_THAT(log, HasSubstr((source / "vlnce.pth").string()));
  EXPECT_THAT(log, HasSubstr("averages the whole 7x7 RGB ResNet map"));
  EXPECT_THAT(log, HasSubstr("--accept-seq2seq-rgb-pooling"));
  EXPECT_FALSE(fs::exists(source / "out" / "ckpt.0.pth"));

  ASSERT_EQ(convert(source, "--accept-seq2seq-rgb-pooling", &log), 0) << log;
  EXPECT_THAT(log, HasSubstr("approximation: "));
  // the tensors are still exact; the logits close, not equal
  expectExactRoundTrip(
      source, /*cma=*/false, "2021",
      {"net.progress_monitor.weight", "net.progress_monitor.bias"});
  EXPECT_GT(maxLogitError(source), 1e-5);
}

TEST_F(ConvertVlnceCheckpointTest, BadCheckpointsAreRefusedNamingTheFile) {
  struct Case {
    std::string name, args, message;
  };
  const fs::path marker = dir_ / "pwned";
  const fs::path legacyMarker = dir_ / "pwned_legacy";
  const std::vector<Case> cases = {
      {"unknown_key", "--extra-key",
       "unknown key(s) in the state_dict: net.extra_head.weight [2, 3]"},
      {"wrong_shape", "--bad-shape",
       "state_dict['net.state_encoder.rnn.weight_hh_l0'] has shape [48, 17], "
       "expected [48, 16]"},
      {"lstm_state", "--set MODEL.STATE_ENCODER.rnn_type=LSTM",
       "unsupported setting MODEL.STATE_ENCODER.rnn_type = 'LSTM'"},
      {"ablation", "--set MODEL.ablate_rgb=True",
       "unsupported setting MODEL.ablate_rgb = True"},
      {"gru_text", "--set MODEL.INSTRUCTION_ENCODER.rnn_type=GRU",
       "unsupported setting MODEL.INSTRUCTION_ENCODER.rnn_type = 'GRU'"},
      {"transforms",
       // (the helper reads [a, b] as a list of words)
       "--set RL.POLICY.OBS_TRANSFORMS.ENABLED_TRANSFORMS=[CenterCropper]",
       "unsupported setting RL.POLICY.OBS_TRANSFORMS.ENABLED_TRANSFORMS = "
       "['CenterCropper']"},
      {"waypoint", "--set MODEL.policy_name=WaypointPolicy",
       "unsupported setting MODEL.policy_name = 'WaypointPolicy'"},
      // a config whose pickle calls os.system("touch <marker>"), in both of
      // torch's file formats
      {"attack", "--attack " + marker.string(),
       "refused: its pickle calls posix.system"},
      {"attack_legacy", "--legacy-format --attack " + legacyMarker.string(),
       "refused: its pickle calls posix.system"},
      {"truncated", "",
       "not a readable torch checkpoint (truncated or corrupt?)"},
  };
  // the smallest model (ResNet-18 on 32x32, DD-PPO's on 64x64), made in one
  // process
  std::string specs;
  for (const Case& c : cases) specs += " '" + c.name + ": " + c.args + "'";
  std::string log;
  ASSERT_EQ(
      python(helperScript(), "make-many " + dir_.path().string() + specs, &log),
      0)
      << log;
  const fs::path truncated = dir_ / "truncated" / "vlnce.pth";
  fs::resize_file(truncated, fs::file_size(truncated) / 2);

  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const fs::path source = dir_ / c.name;
    EXPECT_NE(convert(source, "", &log), 0);
    EXPECT_THAT(log,
                HasSubstr("convert_vlnce_checkpoint: " +
                          (source / "vlnce.pth").string() + ": " + c.message));
    EXPECT_THAT(log, Not(HasSubstr("Traceback")));
    EXPECT_FALSE(fs::exists(source / "out" / "ckpt.0.pth"));
  }
  EXPECT_FALSE(fs::exists(marker)) << "the pickle ran os.system";
  EXPECT_FALSE(fs::exists(legacyMarker)) << "the pickle ran os.system";
}

// ---------------------------------------------------------------------------
// end to end: the eval binary on the tiny world

class ConvertVlnceCheckpointEvalTest : public train::test::TinyWorldBinaryTest {
 protected:
  ConvertVlnceCheckpointEvalTest() : TinyWorldBinaryTest("eval") {}
};

TEST_F(ConvertVlnceCheckpointEvalTest, ConvertedPolicyScoresAsTheSource) {
  if (!havePythonTorch()) GTEST_SKIP() << "/usr/bin/python3 lacks torch";
  // a CMA policy with VLN-CE's encoders and fixed widths, in our format
  vln::test::writeText(
      dir_ / "tiny.yaml",
      train::test::tinyRunConfig(*world_, dir_ / "run", "  epochs: 1\n"));
  const fs::path base = vln::test::writeText(
      dir_ / "base.yaml", "_base_: tiny.yaml\neval:\n  sample_actions: true\n");
  const fs::path ours = dir_ / "ours";
  const std::string oursConfig =
      "_base_: " + base.string() +
      "\n"
      "sim:\n"
      "  depth: {width: 64, height: 64}\n"
      "model:\n"
      "  rgb_encoder: resnet18\n"
      "  depth_encoder: resnet18\n"
      "  depth_resnet_base_planes: 8\n"
      "  depth_height: 64\n"
      "  depth_width: 64\n"
      "  prev_action_embedding_dim: 32\n"
      "  spatial_embedding_dim: 64\n"
      "  normalize_rgb: false\n"
      "  rgb_weights: " +
      (ours / "rgb.pt").string() +
      "\n  depth_weights: " + (ours / "depth.pt").string() + "\n";
  const fs::path oursFile =
      vln::test::writeText(ours / "config.yaml", oursConfig);
  // the weight files do not exist yet: load the config without them
  train::ExperimentConfig config = train::loadExperimentConfig(oursFile);
  torch::manual_seed(5);
  auto policy = models::makePolicy(config.model);
  models::ObservationEncoder encoder(config.model);
  {
    // actions that depend on the observations, and rarely STOP (the
    // evaluation samples them)
    torch::NoGradGuard noGrad;
    policy->named_parameters()["action_head.weight"].mul_(20.0);
    policy->named_parameters()["action_head.bias"][0] = -3.0;
  }
  models::saveModule(encoder->rgb->cnnModule(), ours / "rgb.pt");
  models::saveModule(encoder->depth->cnnModule(), ours / "depth.pt");
  models::writeTensorFile(ours / "policy.pt", models::namedState(*policy));
  train::Checkpoint ckpt;
  ckpt.config_yaml = train::experimentConfigYaml(config);
  ckpt.policy = models::namedState(*policy);
  train::saveCheckpoint(ours / "ckpt.0.pth", ckpt);

  // the same tensors as a VLN-CE checkpoint, converted
  const fs::path vlnce = dir_ / "vlnce";
  std::string log;
  ASSERT_EQ(
      python(helperScript(),
             "from-ours " + (vlnce / "vlnce.pth").string() + " " +
                 (ours / "policy.pt").string() + " " +
                 (ours / "rgb.pt").string() + " " +
                 (ours / "depth.pt").string() + " --policy cma --pm --vocab " +
                 std::to_string(world_->vocab_size) + " --embedding " +
                 std::to_string(world_->embedding_dim) +
                 " --text-hidden 8 --hidden 16 --rgb-out 8 --depth-out 8"
                 " --depth-base 8 --rgb-size 32 --depth-size 64"
                 " --max-steps 120",
             &log),
      0)
      << log;
  ASSERT_EQ(python(converterScript(),
                   (vlnce / "vlnce.pth").string() + " --out-dir " +
                       (vlnce / "out").string() + " --base " + base.string(),
                   &log),
            0)
      << log;

  // both through the eval binary
  auto eval = [&](const fs::path& configFile, const fs::path& checkpoint,
                  const fs::path& out) {
    std::string output;
    EXPECT_EQ(
        vln::test::runCommand(
            vln::test::binary("eval") + " --log-level warn --config " +
                configFile.string() + " --checkpoint " + checkpoint.string() +
                " --split val_unseen --episodes 3 --out " + out.string() +
                " 2>&1",
            &output),
        0)
        << output;
    EXPECT_THAT(output, HasSubstr("ckpt 0 val_unseen: 3 episodes"));
  };
  eval(oursFile, ours / "ckpt.0.pth", dir_ / "eval_ours");
  eval(vlnce / "out" / "config.yaml", vlnce / "out" / "ckpt.0.pth",
       dir_ / "eval_converted");
  const std::string stats = rollout::statsFileName(0, "val_unseen");
  const auto ourStats = rollout::readStatsFile(dir_ / "eval_ours" / stats);
  EXPECT_EQ(rollout::readStatsFile(dir_ / "eval_converted" / stats), ourStats);
  EXPECT_GT(ourStats.mean.path_length, 0.5);  // the policy walked
  RecordProperty("path_length", std::to_string(ourStats.mean.path_length));
  RecordProperty("distance_to_goal",
                 std::to_string(ourStats.mean.distance_to_goal));
  const std::string episodes = rollout::episodesFileName(0, "val_unseen");
  const auto a = rollout::readEpisodesFile(dir_ / "eval_ours" / episodes);
  const auto b = rollout::readEpisodesFile(dir_ / "eval_converted" / episodes);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i)
    EXPECT_EQ(a[i].record.actions, b[i].record.actions);
}

}  // namespace
}  // namespace vln::eval
