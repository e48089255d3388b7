#pragma once
// Shared by the learner tests (ImitationLearnerTest.cpp, DistributedTest.cpp):
// a Seq2Seq policy small enough to train in milliseconds, and the feature
// store layout that matches it.

#include "models/ModelConfig.h"
#include "train/ExperimentConfig.h"
#include "train/FeatureStore.h"

namespace vln::train::test {

/// Seq2Seq with small CNNs on 32x32 images, every width a few units, the
/// progress monitor on (its loss is averaged over steps, the action loss over
/// episodes: both paths get exercised), lr 1e-2, at most 3 non-finite
/// updates in a row.
inline ExperimentConfig tinyLearnerConfig(int batchSize) {
  ExperimentConfig c;
  c.model.policy = models::PolicyType::kSeq2Seq;
  c.model.rgb_encoder = models::EncoderType::kSmallCnn;
  c.model.depth_encoder = models::EncoderType::kSmallCnn;
  c.model.vocab_size = 11;
  c.model.embedding_dim = 4;
  c.model.instruction_hidden_size = 6;
  c.model.hidden_size = 12;
  c.model.rgb_projection_size = 5;
  c.model.depth_projection_size = 7;
  c.model.progress_monitor = true;
  c.model.rgb_height = c.model.rgb_width = 32;
  c.model.depth_height = c.model.depth_width = 32;
  c.trainer.batch_size = batchSize;
  c.trainer.lr = 1e-2;
  c.trainer.max_nonfinite_updates = 3;
  return c;
}

/// The float32 store layout of `c`'s feature shapes.
inline StoreLayout layoutOf(const ExperimentConfig& c) {
  StoreLayout l;
  l.rgb_shape = models::rgbFeatureShape(c.model);
  l.depth_shape = models::depthFeatureShape(c.model);
  l.fp16 = false;
  l.config_hash = "test";
  return l;
}

}  // namespace vln::train::test
