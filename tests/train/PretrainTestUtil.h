#pragma once
// Shared by the pretraining task tests (PointNavPretrainerTest.cpp,
// SemanticPretrainerTest.cpp): the settings of a tiny run, the metrics log
// read back (support/TestUtil.h) with its epochs' learning rates, and the check
// that an encoder file loaded into a VLN model's encoder as it was saved.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "models/ObservationEncoder.h"
#include "models/StateDict.h"
#include "support/TestUtil.h"
#include "train/ExperimentConfig.h"

namespace vln::train::test {

/// trainer.task = `task` writing to `runDir`, one LibTorch thread and two
/// rendering threads, small CNNs on 32x32 images (model and sensors), and
/// pretraining houses of 2 to 3 rooms without floor holes; the house
/// counts, samples and optimisation are left to each test.
inline ExperimentConfig tinyPretrainConfig(
    const std::string& task, const std::filesystem::path& runDir) {
  ExperimentConfig c;
  c.trainer.task = task;
  c.trainer.torch_threads = 1;
  c.trainer.env_threads = 2;
  c.model.rgb_encoder = models::EncoderType::kSmallCnn;
  c.model.depth_encoder = models::EncoderType::kSmallCnn;
  c.model.rgb_width = c.model.rgb_height = 32;
  c.model.depth_width = c.model.depth_height = 32;
  c.sim.rgb.width = c.sim.rgb.height = 32;
  c.sim.depth.camera.width = c.sim.depth.camera.height = 32;
  c.pretrain.house.min_rooms = 2;
  c.pretrain.house.max_rooms = 3;
  c.pretrain.house.floor_hole_probability = 0.0f;
  c.output.dir = runDir.string();
  return c;
}

using vln::test::readJsonLines;

/// The "lr" of every "epoch" record in a pretraining run's metrics.jsonl,
/// in order: the rate each epoch's updates took.
inline std::vector<double> epochLearningRates(
    const std::filesystem::path& metrics) {
  std::vector<double> rates;
  for (const auto& line : readJsonLines(metrics))
    if (line["type"] == "epoch") rates.push_back(line["lr"].get<double>());
  return rates;
}

/// Expects the tensors `loaded` into an encoder (models::namedState() after
/// loadPretrained()) to be those `saved` in its weight file, name by name,
/// and frozen.
inline void expectLoadedFrozen(const models::NamedTensors& saved,
                               const models::NamedTensors& loaded) {
  ASSERT_EQ(saved.size(), loaded.size());
  for (size_t i = 0; i < saved.size(); ++i) {
    EXPECT_EQ(saved[i].first, loaded[i].first);
    EXPECT_TRUE(torch::equal(saved[i].second, loaded[i].second))
        << saved[i].first;
    EXPECT_FALSE(loaded[i].second.requires_grad())
        << saved[i].first << " is not frozen";
  }
}

/// Expects loadPretrained() of an observation encoder built from `config`
/// to throw std::invalid_argument naming every one of `names` (the weight
/// file, mismatched tensors); `what` says what must not load.
inline void expectLoadRejected(const models::ModelConfig& config,
                               const std::string& what,
                               const std::vector<std::string>& names) {
  models::ObservationEncoder encoder(config);
  try {
    encoder->loadPretrained();
    FAIL() << what;
  } catch (const std::invalid_argument& e) {
    for (const auto& name : names)
      EXPECT_THAT(e.what(), ::testing::HasSubstr(name));
  }
}

}  // namespace vln::train::test
