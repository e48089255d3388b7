// scripts/convert_torchvision_resnet50.py and scripts/convert_ddppo_depth.py
// turn checkpoints laid out like torchvision's state dict and DD-PPO's
// training checkpoint into archives the C++ encoders load strictly. The
// checkpoints are synthesised here from the C++ modules' own tensors (by
// Python, in the source formats), so the round trip must reproduce the
// encoders' outputs exactly. Skipped when /usr/bin/python3 lacks torch.
#include <gtest/gtest.h>

#include "ModelTestUtil.h"
#include "models/ObservationEncoder.h"
#include "models/StateDict.h"
#include "support/TestPaths.h"

namespace vln::models {
namespace {

bool havePythonTorch() {
  return vln::test::runCommand("/usr/bin/python3 -c 'import torch'") == 0;
}

std::string python(const std::filesystem::path& script,
                   const std::string& args) {
  std::string log;
  const int status = vln::test::runCommand(
      "/usr/bin/python3 " + script.string() + " " + args, &log);
  EXPECT_EQ(status, 0) << log;
  return log;
}

TEST(ConvertScriptsTest, DdppoCheckpointLoadsIntoDepthEncoder) {
  if (!havePythonTorch()) GTEST_SKIP() << "/usr/bin/python3 lacks torch";
  ModelConfig c = test::tinyConfig(PolicyType::kCma);
  c.depth_encoder = EncoderType::kResNet18;
  c.depth_resnet_base_planes = 8;
  c.depth_height = c.depth_width = 64;
  c.no_rgb = true;
  torch::manual_seed(21);
  ObservationEncoder source(c);
  vln::test::TempDir dir;
  saveModule(source->depth->cnnModule(), dir / "tensors.pt");

  // a DD-PPO training checkpoint: the encoder under the actor-critic prefix,
  // other networks beside it, and a pickled config whose class cannot be
  // imported by the converter
  vln::test::writeText(dir / "make.py", R"PY(
import sys, torch
class HabitatConfig(dict):
    pass
tensors = dict(torch.jit.load(sys.argv[1]).named_buffers())
state = {"actor_critic.net.visual_encoder." + k: v for k, v in tensors.items()}
state["actor_critic.net.state_encoder.rnn.weight_ih_l0"] = torch.zeros(3, 2)
state["actor_critic.action_distribution.linear.weight"] = torch.zeros(4, 2)
config = HabitatConfig(RL={"PPO": {"hidden_size": 512}})
torch.save({"state_dict": state, "config": config}, sys.argv[2])
)PY");
  python(dir / "make.py",
         (dir / "tensors.pt").string() + " " + (dir / "ddppo.pth").string());
  const std::string log = python(
      vln::test::sourcePath() / "scripts" / "convert_ddppo_depth.py",
      (dir / "ddppo.pth").string() + " --out " + (dir / "depth.pt").string());
  EXPECT_NE(log.find("base width 8"), std::string::npos) << log;

  torch::manual_seed(22);
  c.depth_weights = (dir / "depth.pt").string();
  ObservationEncoder loaded(c);
  loaded->loadPretrained();
  torch::NoGradGuard g;
  const torch::Tensor depth = torch::rand({2, 64, 64, 1});
  EXPECT_TRUE(torch::equal(source->forward({}, depth).depth,
                           loaded->forward({}, depth).depth));
}

TEST(ConvertScriptsTest, TorchvisionStateDictLoadsIntoRgbEncoder) {
  if (!havePythonTorch()) GTEST_SKIP() << "/usr/bin/python3 lacks torch";
  ModelConfig c = test::tinyConfig(PolicyType::kCma);
  c.rgb_encoder = EncoderType::kResNet18;
  c.no_depth = true;
  torch::manual_seed(23);
  ObservationEncoder source(c);
  {
    torch::NoGradGuard g;
    for (auto& item : source->named_buffers())
      if (item.key().find("running_var") != std::string::npos)
        item.value().uniform_(0.5, 2.0);
  }
  vln::test::TempDir dir;
  // torchvision's state dict also holds the ImageNet classifier
  NamedTensors tensors = namedState(source->rgb->cnnModule());
  tensors.emplace_back("fc.weight", torch::randn({1000, 512}));
  tensors.emplace_back("fc.bias", torch::randn({1000}));
  writeTensorFile(dir / "tensors.pt", tensors);
  vln::test::writeText(dir / "make.py", R"PY(
import sys, torch
tensors = dict(torch.jit.load(sys.argv[1]).named_buffers())
torch.save(tensors, sys.argv[2])
)PY");
  python(dir / "make.py",
         (dir / "tensors.pt").string() + " " + (dir / "resnet18.pth").string());
  python(
      vln::test::sourcePath() / "scripts" / "convert_torchvision_resnet50.py",
      "--arch resnet18 --state-dict " + (dir / "resnet18.pth").string() +
          " --out " + (dir / "rgb.pt").string());

  torch::manual_seed(24);
  c.rgb_weights = (dir / "rgb.pt").string();
  ObservationEncoder loaded(c);
  loaded->loadPretrained();
  torch::NoGradGuard g;
  const torch::Tensor rgb =
      torch::randint(0, 256, {2, 32, 32, 3}, torch::kUInt8);
  EXPECT_TRUE(
      torch::equal(source->forward(rgb, {}).rgb, loaded->forward(rgb, {}).rgb));
}

}  // namespace
}  // namespace vln::models
