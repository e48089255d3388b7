// The pretraining tasks through the `train` binary, with the shipped configs
// (configs/pretrain/) shrunk by --set to a few seconds: what a user runs.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/Json.h"
#include "models/StateDict.h"
#include "support/TestPaths.h"

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string trainBinary() { return (vln::test::binaryPath() / "bin" / "train").string(); }

// the shipped config at 32x32 on 2 + 1 small houses
std::string tinyCommand(const std::string& config, const fs::path& dir,
                        const std::string& extra) {
  std::string command = trainBinary() + " --config " +
                        (vln::test::sourcePath() / "configs" / "pretrain" / config).string();
  for (const std::string set :
       {"sim.rgb.width=32", "sim.rgb.height=32", "sim.depth.width=32", "sim.depth.height=32",
        "model.rgb_width=32", "model.rgb_height=32", "model.depth_width=32",
        "model.depth_height=32", "pretrain.train_houses=2", "pretrain.heldout_houses=1",
        "pretrain.house.min_rooms=2", "pretrain.house.max_rooms=3", "pretrain.samples=20",
        "pretrain.iterations=1", "pretrain.eval_samples=10", "trainer.num_envs=4",
        "output.log_level=warn"})
    command += " --set " + set;
  command += " --set output.dir=" + (dir / "run").string();
  command += " --set pretrain.encoder_out=" + (dir / "encoder.pt").string();
  return command + " " + extra + " 2>&1";
}

class PretrainCommandTest : public ::testing::TestWithParam<const char*> {};

TEST_P(PretrainCommandTest, ShippedConfigTrainsAndSavesTheEncoder) {
  if (!fs::exists(trainBinary())) GTEST_SKIP() << "build the train binary first";
  vln::test::TempDir dir;
  const std::string config = GetParam();
  std::string output;
  ASSERT_EQ(vln::test::runCommand(tinyCommand(config, dir.path(), ""), &output), 0) << output;

  const nlohmann::json metrics = common::readJsonFile(dir / "run" / "pretrain_metrics.json");
  EXPECT_EQ(metrics["task"], config == std::string("rgb_semantic.yaml") ? "rgb_semantic"
                                                                         : "depth_pointnav");
  EXPECT_TRUE(fs::exists(dir / "run" / "config.yaml"));
  const models::NamedTensors encoder = models::readTensorFile(dir / "encoder.pt");
  EXPECT_FALSE(encoder.empty());

  // a pretraining run keeps no resumable state: --resume is refused, and
  // so is --export (it trains an encoder, not a policy)
  EXPECT_NE(vln::test::runCommand(tinyCommand(config, dir.path(), "--resume"), &output), 0);
  EXPECT_THAT(output, HasSubstr("cannot resume"));
  vln::test::TempDir other;
  EXPECT_NE(vln::test::runCommand(
                tinyCommand(config, other.path(), "--export " + (other / "p.pt").string()),
                &output),
            0);
  EXPECT_THAT(output, HasSubstr("not a policy"));
}

INSTANTIATE_TEST_SUITE_P(Configs, PretrainCommandTest,
                         ::testing::Values("rgb_semantic.yaml", "depth_pointnav.yaml"));

}  // namespace
}  // namespace vln::train
