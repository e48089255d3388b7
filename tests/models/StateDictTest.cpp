#include "models/StateDict.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "common/FileIo.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::models {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using vln::test::errorOf;

// a module with nested names, a parameter and buffers
struct NetImpl : torch::nn::Module {
  NetImpl() {
    fc = register_module("fc", torch::nn::Linear(3, 2));
    seq = register_module("seq",
                          torch::nn::Sequential(torch::nn::Conv2d(1, 2, 3),
                                                torch::nn::BatchNorm2d(2)));
  }
  torch::nn::Linear fc{nullptr};
  torch::nn::Sequential seq{nullptr};
};
TORCH_MODULE(Net);

TEST(StateDictTest, NamedStateHasParametersThenBuffersWithDottedNames) {
  Net net;
  std::vector<std::string> names;
  for (const auto& [name, t] : namedState(*net)) names.push_back(name);
  EXPECT_THAT(names, ::testing::ElementsAre(
                         "fc.weight", "fc.bias", "seq.0.weight", "seq.0.bias",
                         "seq.1.weight", "seq.1.bias", "seq.1.running_mean",
                         "seq.1.running_var", "seq.1.num_batches_tracked"));
}

TEST(StateDictTest, FileRoundTripRestoresEveryTensor) {
  torch::manual_seed(1);
  Net a;
  Net b;
  {
    torch::NoGradGuard g;
    a->seq[1]->as<torch::nn::BatchNorm2d>()->running_mean.fill_(0.25);
  }
  vln::test::TempDir dir;
  saveModule(*a, dir / "sub" / "net.pt");
  loadModule(*b, dir / "sub" / "net.pt");
  const auto sa = namedState(*a);
  const auto sb = namedState(*b);
  ASSERT_EQ(sa.size(), sb.size());
  for (size_t i = 0; i < sa.size(); ++i)
    EXPECT_TRUE(torch::equal(sa[i].second, sb[i].second)) << sa[i].first;
}

TEST(StateDictTest, StrictLoadListsEveryProblemWithNamesAndShapes) {
  Net net;
  NamedTensors tensors = namedState(*net);
  const torch::Tensor before = net->fc->weight.clone();
  // drop one, reshape one, add one
  tensors.erase(tensors.begin() + 1);  // fc.bias
  tensors[0].second = torch::zeros({5, 3});
  tensors.emplace_back("head.weight", torch::zeros({4, 7}));
  const std::string msg =
      errorOf([&] { loadStateStrict(*net, tensors, "ckpt.pt"); });
  EXPECT_THAT(msg, HasSubstr("ckpt.pt"));
  EXPECT_THAT(msg, HasSubstr("missing (1):\n    fc.bias [2]"));
  EXPECT_THAT(msg, HasSubstr("unexpected (1):\n    head.weight [4, 7]"));
  EXPECT_THAT(msg, HasSubstr("fc.weight expected [2, 3], got [5, 3]"));
  // a failed load leaves the module unchanged
  EXPECT_TRUE(torch::equal(net->fc->weight, before));
}

TEST(StateDictTest, StrictLoadRejectsDuplicates) {
  Net net;
  NamedTensors tensors = namedState(*net);
  tensors.push_back(tensors.front());
  EXPECT_THAT(errorOf([&] { loadStateStrict(*net, tensors); }),
              HasSubstr("duplicate (1):\n    fc.weight"));
}

TEST(StateDictTest, StrictLoadConvertsDtype) {
  Net net;
  NamedTensors tensors = namedState(*net);
  for (auto& [name, t] : tensors)
    if (t.is_floating_point()) t = torch::ones_like(t, torch::kDouble);
  loadStateStrict(*net, tensors);
  EXPECT_EQ(net->fc->weight.scalar_type(), torch::kFloat32);
  EXPECT_TRUE(torch::equal(net->fc->weight, torch::ones({2, 3})));
}

TEST(StateDictTest, StripPrefixKeepsOnlyMatchingNames) {
  const NamedTensors in = {
      {"actor_critic.net.visual_encoder.backbone.conv1.0.weight",
       torch::zeros({1})},
      {"actor_critic.net.state_encoder.rnn.weight_ih_l0", torch::zeros({1})}};
  const NamedTensors out = stripPrefix(in, "actor_critic.net.visual_encoder.");
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].first, "backbone.conv1.0.weight");
}

TEST(StateDictTest, MissingAndCorruptFilesNameTheFile) {
  vln::test::TempDir dir;
  EXPECT_THAT(errorOf([&] { readTensorFile(dir / "none.pt"); }),
              HasSubstr("none.pt' does not exist"));
  vln::test::writeText(dir / "bad.pt", "not a zip archive");
  EXPECT_THAT(errorOf([&] { readTensorFile(dir / "bad.pt"); }),
              HasSubstr("bad.pt' is not an intact zip archive"));
  // one flipped byte in a tensor: LibTorch would read it without a word
  torch::manual_seed(1);
  writeTensorFile(dir / "w.pt", {{"w", torch::randn({64})}});
  std::string bytes = common::readFile(dir / "w.pt");
  const size_t data = bytes.find("archive/data/0");
  ASSERT_NE(data, std::string::npos);
  bytes[data + 100] ^= 0x40;
  vln::test::writeText(dir / "flipped.pt", bytes);
  EXPECT_THAT(errorOf([&] { readTensorFile(dir / "flipped.pt"); }),
              HasSubstr("flipped.pt' is not an intact zip archive"));
}

TEST(StateDictTest, WriteRejectsConflictingNames) {
  vln::test::TempDir dir;
  const NamedTensors clash = {{"a", torch::zeros({1})},
                              {"a.b", torch::zeros({1})}};
  EXPECT_THAT(errorOf([&] { writeTensorFile(dir / "x.pt", clash); }),
              HasSubstr("nests under 'a', which is itself a tensor"));
  const NamedTensors twice = {{"a.b", torch::zeros({1})},
                              {"a.b", torch::zeros({1})}};
  EXPECT_THAT(errorOf([&] { writeTensorFile(dir / "y.pt", twice); }),
              HasSubstr("'a.b' is used twice"));
  EXPECT_FALSE(std::filesystem::exists(dir / "x.pt"));
}

}  // namespace
}  // namespace vln::models
