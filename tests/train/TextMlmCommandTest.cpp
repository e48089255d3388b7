// trainer.task = text_mlm through the `train` binary with the shipped
// config (configs/rxr/text_encoder.yaml), shrunk by --set to a toy corpus:
// what a user runs.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/Json.h"
#include "data/RxrTextFeatures.h"
#include "support/TestPaths.h"
#include "train/TextCorpusTestUtil.h"

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string trainBinary() {
  return (vln::test::binaryPath() / "bin" / "train").string();
}

std::string command(const test::ToyCorpus& toy, const fs::path& dir,
                    const std::string& extra) {
  std::string c =
      trainBinary() + " --config " +
      (vln::test::sourcePath() / "configs" / "rxr" / "text_encoder.yaml")
          .string();
  for (const std::string set :
       {"pretrain.text.r2r_train_splits=[train]",
        "pretrain.text.r2r_heldout_splits=[val_unseen]",
        "pretrain.text.rxr_heldout_splits=[val_unseen]",
        "pretrain.text.feature_splits=[train,val_unseen]",
        "pretrain.text.epochs=2", "pretrain.text.encoder.hidden_size=16",
        "pretrain.text.encoder.ff_size=16", "pretrain.text.encoder.layers=1",
        "trainer.torch_threads=1", "output.log_level=warn"})
    c += " --set " + set;
  c += " --set pretrain.text.r2r_path=" + toy.r2r.string();
  c += " --set pretrain.text.rxr_path=" + toy.rxr.string();
  c += " --set output.dir=" + (dir / "run").string();
  c += " --set pretrain.encoder_out=" + (dir / "text.pt").string();
  return c + " " + extra + " 2>&1";
}

TEST(TextMlmCommandTest, ShippedConfigWritesTheRxrFeatureFiles) {
  if (!fs::exists(trainBinary()))
    GTEST_SKIP() << "build the train binary first";
  vln::test::TempDir dir;
  const test::ToyCorpus toy = test::writeToyCorpus(dir / "data");
  std::string output;
  ASSERT_EQ(vln::test::runCommand(command(toy, dir.path(), ""), &output), 0)
      << output;

  const nlohmann::json metrics =
      common::readJsonFile(dir / "run" / "pretrain_metrics.json");
  EXPECT_EQ(metrics["task"], "text_mlm");
  EXPECT_GT(metrics["heldout"]["masked_tokens"].get<int64_t>(), 0);
  EXPECT_TRUE(fs::exists(dir / "run" / "config.yaml"));
  EXPECT_TRUE(fs::exists(dir / "text.pt"));
  EXPECT_TRUE(fs::exists(dir / "text.vocab.json"));
  // the default features_dir is where the RxR reader looks
  for (const auto& [split, id, language] : toy.rxr_instructions) {
    const data::RxrTextFeatures features = data::loadRxrTextFeatures(
        toy.rxr / "text_features", split, id, language);
    ASSERT_EQ(features.valid_tokens, 21) << split << " " << id;
  }

  // a pretraining run keeps no resumable state
  EXPECT_NE(
      vln::test::runCommand(command(toy, dir.path(), "--resume"), &output), 0);
  EXPECT_THAT(output, HasSubstr("cannot resume"));
  // a bad encoder shape is refused before anything runs
  vln::test::TempDir other;
  EXPECT_NE(
      vln::test::runCommand(
          command(toy, other.path(), "--set pretrain.text.encoder.heads=3"),
          &output),
      0);
  EXPECT_THAT(output, HasSubstr("multiple of heads"));
}

}  // namespace
}  // namespace vln::train
