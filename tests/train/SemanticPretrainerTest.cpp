// Tests of src/train/SemanticPretrainer.cpp (its view labels are
// tests/world/ViewLabelsTest.cpp's): average precision and F1 against
// values worked out by hand, config errors, and one tiny end-to-end run that
// must beat the label-prior predictor on a held-out house, is repeatable by
// seed, and whose RGB encoder loads strictly into a VLN model's frozen RGB
// encoder but not into a different one.

#include "train/SemanticPretrainer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "common/Json.h"
#include "models/StateDict.h"
#include "support/TestPaths.h"
#include "train/PretrainTasks.h"
#include "train/PretrainTestUtil.h"

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// Two small training houses and one held-out house, 32x32 RGB, a small CNN.
ExperimentConfig tinyConfig(const fs::path& runDir) {
  ExperimentConfig c = test::tinyPretrainConfig("rgb_semantic", runDir);
  c.trainer.seed = 5;
  c.trainer.log_every_updates = 10;
  // fewer training houses than this and the network learns those houses'
  // labels rather than what objects look like (held-out mAP below the prior)
  c.pretrain.train_houses = 6;
  c.pretrain.heldout_houses = 2;
  c.pretrain.house_seed = 777;
  c.pretrain.samples = 400;
  c.pretrain.iterations = 6;
  c.pretrain.batch_size = 32;
  c.pretrain.lr = 2e-3;
  c.pretrain.eval_samples = 200;
  c.pretrain.min_object_fraction = 0.03f;
  c.pretrain.encoder_out = (runDir / "rgb_cnn.pt").string();
  return c;
}

// ---------------------------------------------------------------------------
// metrics

TEST(AveragePrecisionTest, HandComputedValues) {
  // positives at ranks 1 and 3: (1/1 + 2/3) / 2
  const std::vector<float> scores = {0.9f, 0.8f, 0.7f, 0.6f};
  EXPECT_NEAR(averagePrecision(scores, std::vector<uint8_t>{1, 0, 1, 0}), (1.0 + 2.0 / 3.0) / 2.0,
              1e-12);
  EXPECT_NEAR(averagePrecision(scores, std::vector<uint8_t>{0, 0, 0, 1}), 0.25, 1e-12);
  EXPECT_NEAR(averagePrecision(scores, std::vector<uint8_t>{1, 1, 0, 0}), 1.0, 1e-12);
  // a constant score is one threshold: AP = prevalence
  const std::vector<float> constant(8, 0.3f);
  EXPECT_NEAR(averagePrecision(constant, std::vector<uint8_t>{1, 0, 0, 1, 0, 0, 0, 0}), 0.25,
              1e-12);
  // ties inside a ranking: {0.9} then {0.5, 0.5} -> (1 + 2/3) / 2
  EXPECT_NEAR(averagePrecision(std::vector<float>{0.9f, 0.5f, 0.5f},
                               std::vector<uint8_t>{1, 0, 1}),
              (1.0 + 2.0 / 3.0) / 2.0, 1e-12);
  EXPECT_TRUE(std::isnan(averagePrecision(scores, std::vector<uint8_t>{0, 0, 0, 0})));
  EXPECT_THROW(averagePrecision(scores, std::vector<uint8_t>{1}), std::invalid_argument);
}

TEST(MultiLabelMetricsTest, MicroAndMacroF1OverLabelsWithPositives) {
  // 3 images x 3 labels; label 2 has no positive and is left out of the
  // means (but its false positive counts in micro F1)
  const std::vector<float> p = {0.9f, 0.2f, 0.6f,   //
                                0.8f, 0.7f, 0.1f,   //
                                0.1f, 0.4f, 0.2f};
  const std::vector<uint8_t> y = {1, 1, 0,  //
                                  0, 1, 0,  //
                                  1, 0, 0};
  const MultiLabelMetrics m = multiLabelMetrics(p, y, 3);
  EXPECT_EQ(m.labels_evaluated, 2);
  // label 0: predicted {0, 1}, true {0, 2}: tp 1 fp 1 fn 1 -> F1 0.5;
  // label 1: predicted {1}, true {0, 1}: tp 1 fn 1 -> F1 2/3
  EXPECT_NEAR(m.macro_f1, (0.5 + 2.0 / 3.0) / 2.0, 1e-12);
  // pooled: tp 2, fp 1 + 0 + 1, fn 1 + 1 -> 4 / (4 + 2 + 2)
  EXPECT_NEAR(m.micro_f1, 0.5, 1e-12);
  // AP: label 0 scores (0.9 +, 0.8 -, 0.1 +) -> (1 + 2/3) / 2;
  // label 1 scores (0.7 +, 0.4 -, 0.2 +) -> (1 + 2/3) / 2
  EXPECT_NEAR(m.ap[0], (1.0 + 2.0 / 3.0) / 2.0, 1e-12);
  EXPECT_NEAR(m.mean_ap, (1.0 + 2.0 / 3.0) / 2.0, 1e-12);
  EXPECT_TRUE(std::isnan(m.ap[2]));
}

// ---------------------------------------------------------------------------
// config errors

TEST(SemanticPretrainerTest, BadConfigValuesAreNamed) {
  vln::test::TempDir dir;
  auto expectError = [&](const std::function<void(ExperimentConfig&)>& change,
                         const std::string& key) {
    ExperimentConfig c = tinyConfig(dir.path());
    change(c);
    try {
      SemanticPretrainer pretrainer(c, dir.path());
      ADD_FAILURE() << "accepted a bad " << key;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr(key));
    }
  };
  expectError([](ExperimentConfig& c) { c.model.no_rgb = true; }, "model.no_rgb");
  expectError([](ExperimentConfig& c) { c.pretrain.min_object_fraction = 0.0f; },
              "pretrain.min_object_fraction");
  expectError([](ExperimentConfig& c) { c.model.rgb_width = 48; }, "model.rgb_width x rgb_height (48x32)");
  expectError([](ExperimentConfig& c) { c.trainer.task = "depth_pointnav"; }, "trainer.task");
}

// ---------------------------------------------------------------------------
// end to end

TEST(SemanticPretrainerTest, BeatsThePriorAndSavesALoadableRgbEncoder) {
  vln::test::TempDir dir;
  const ExperimentConfig c = tinyConfig(dir.path());
  SemanticPretrainer pretrainer(c, dir.path());
  const SemanticResult r = pretrainer.run();

  // it learned from the image: better than the predictor that ignores it
  // (by a ratio: on so few houses absolute margins vary with the seed)
  EXPECT_LT(r.final_loss, 0.7 * r.initial_loss)
      << "initial " << r.initial_loss << " final " << r.final_loss;
  EXPECT_GT(r.model.categories.mean_ap, 1.5 * r.prior.categories.mean_ap)
      << "network " << r.model.categories.mean_ap << " prior " << r.prior.categories.mean_ap;
  EXPECT_GT(r.model.colors.mean_ap, 1.5 * r.prior.colors.mean_ap)
      << "network " << r.model.colors.mean_ap << " prior " << r.prior.colors.mean_ap;
  EXPECT_GT(r.model.room_accuracy, r.prior.room_accuracy)
      << "network " << r.model.room_accuracy << " prior " << r.prior.room_accuracy;
  EXPECT_EQ(r.model.images, 200);
  EXPECT_EQ(r.train_images, c.pretrain.samples * c.pretrain.iterations);
  EXPECT_GT(r.model.categories.labels_evaluated, 3);

  const nlohmann::json summary = common::readJsonFile(dir / "pretrain_metrics.json");
  EXPECT_EQ(summary["task"], "rgb_semantic");
  for (const char* who : {"network", "prior"}) {
    const auto& m = summary["heldout"][who];
    for (const char* key : {"room_accuracy"})
      EXPECT_TRUE(m[key].is_number() && std::isfinite(m[key].get<double>())) << who << key;
    for (const char* head : {"categories", "colors"})
      for (const char* key : {"mean_ap", "micro_f1", "macro_f1"})
        EXPECT_TRUE(m[head][key].is_number() && std::isfinite(m[head][key].get<double>()))
            << who << " " << head << " " << key;
  }
  EXPECT_DOUBLE_EQ(summary["heldout"]["network"]["room_accuracy"].get<double>(),
                   r.model.room_accuracy);
  int epochs = 0;
  for (const auto& line : test::readJsonLines(dir / "metrics.jsonl"))
    epochs += line["type"] == "epoch";
  EXPECT_EQ(epochs, c.pretrain.iterations);

  // the encoder loads strictly, frozen, into a VLN model's RGB encoder
  models::ModelConfig vln = c.model;
  vln.rgb_weights = r.encoder_file.string();
  models::ObservationEncoder encoder(vln);
  encoder->loadPretrained();
  test::expectLoadedFrozen(models::readTensorFile(dir / "rgb_cnn.pt"),
                           models::namedState(encoder->rgb->cnnModule()));
  // ... and not into a ResNet-18: every mismatch is listed
  models::ModelConfig other = vln;
  other.rgb_encoder = models::EncoderType::kResNet18;
  test::expectLoadRejected(
      other, "a small CNN's tensors loaded into a ResNet-18",
      {"rgb_cnn.pt", "cnn.0.weight", "layer1.0.conv1.weight"});

  // the same seed gives the same encoder (a shorter run keeps this cheap)
  ExperimentConfig shortRun = c;
  shortRun.pretrain.iterations = 1;
  shortRun.pretrain.samples = 64;
  shortRun.pretrain.eval_samples = 16;
  std::vector<models::NamedTensors> runs;
  for (int i = 0; i < 2; ++i) {
    vln::test::TempDir again;
    shortRun.output.dir = again.path().string();
    shortRun.pretrain.encoder_out = (again / "rgb.pt").string();
    SemanticPretrainer(shortRun, again.path()).run();
    runs.push_back(models::readTensorFile(again / "rgb.pt"));
  }
  ASSERT_EQ(runs[0].size(), runs[1].size());
  for (size_t i = 0; i < runs[0].size(); ++i)
    EXPECT_TRUE(torch::equal(runs[0][i].second, runs[1][i].second)) << runs[0][i].first;
}

TEST(SemanticPretrainerTest, ACosineScheduleAnnealsTheEpochsRates) {
  // three short epochs; the rate each epoch's updates took is logged from
  // the optimizer
  ExperimentConfig c = tinyConfig({});
  c.pretrain.iterations = 3;
  c.pretrain.samples = 64;
  c.pretrain.eval_samples = 16;
  std::vector<models::NamedTensors> encoders;
  for (const std::string schedule : {"constant", "cosine"}) {
    SCOPED_TRACE(schedule);
    vln::test::TempDir dir;
    c.output.dir = dir.path().string();
    c.pretrain.encoder_out = (dir / "rgb.pt").string();
    c.pretrain.lr_schedule = schedule;
    SemanticPretrainer(c, dir.path()).run();
    const std::vector<double> rates =
        test::epochLearningRates(dir / "metrics.jsonl");
    ASSERT_EQ(rates.size(), 3u);
    const double lr = c.pretrain.lr;
    if (schedule == "constant") {
      EXPECT_THAT(rates, ::testing::Each(::testing::DoubleEq(lr)));
    } else {
      // epoch e of 3 at (1 + cos(pi e / 3)) / 2
      EXPECT_THAT(rates,
                  ::testing::ElementsAre(::testing::DoubleEq(lr),
                                         ::testing::DoubleEq(0.75 * lr),
                                         ::testing::DoubleEq(0.25 * lr)));
    }
    encoders.push_back(models::readTensorFile(dir / "rgb.pt"));
  }
  // the same seed and first epoch, then smaller steps: other weights
  ASSERT_EQ(encoders[0].size(), encoders[1].size());
  bool differ = false;
  for (size_t i = 0; i < encoders[0].size(); ++i)
    differ =
        differ || !torch::equal(encoders[0][i].second, encoders[1][i].second);
  EXPECT_TRUE(differ);
}

}  // namespace
}  // namespace vln::train
