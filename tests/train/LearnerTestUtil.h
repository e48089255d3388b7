#pragma once
// Shared by the learner tests (ImitationLearnerTest.cpp, DistributedTest.cpp):
// a Seq2Seq policy small enough to train in milliseconds, made-up oracle
// actions of stored episodes, and the feature store layout that matches it.

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

/// Gives `e`, episode number `i` with `steps` steps, a made-up oracle
/// trajectory (1 + (i + t) % 3 at step t, STOP last) with the previous
/// actions and progress labels that follow from it.
inline void setMadeUpActions(StoredEpisode& e, int i, int steps) {
  for (int t = 0; t < steps; ++t) {
    const int action = t == steps - 1 ? 0 : 1 + (i + t) % 3;
    e.oracle_actions.push_back(static_cast<uint8_t>(action));
    e.prev_actions.push_back(static_cast<uint8_t>(
        t == 0 ? 0 : e.oracle_actions[static_cast<size_t>(t - 1)]));
    e.progress.push_back(static_cast<float>(t + 1) / static_cast<float>(steps));
  }
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
