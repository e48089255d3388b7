#pragma once
// The episodes a VLN run learns from: dataset.train_split (capped by
// dataset.max_train_episodes), dataset.extra_train_splits and, with
// trainer.use_aug, dataset.aug_split (capped by dataset.max_aug_episodes);
// the pool that collection rounds draw from (train first, then aug, then the
// extra splits); and the word embeddings the policy starts from.

#include <ATen/core/Tensor.h>

#include <cstdint>
#include <memory>
#include <vector>

#include "data/Split.h"
#include "train/ExperimentConfig.h"

namespace vln::train {

struct TrainingData {
  data::Split train;
  std::unique_ptr<data::Split> aug;  ///< null without trainer.use_aug
  /// dataset.extra_train_splits, in order (unique_ptr: the pool points
  /// into them).
  std::vector<std::unique_ptr<data::Split>> extra;
  /// The pool: every train episode, then every aug episode, then every
  /// episode of the extra splits.
  std::vector<const data::Episode*> pool;
  /// Per pool episode: 0 train, 1 aug, 2 + k extra split k (episode ids are
  /// unique only within a split; the feature store keys on both).
  std::vector<uint8_t> sources;

  /// Loads the splits and logs their sizes. Throws std::invalid_argument
  /// naming dataset.train_split (or an extra split) when it has no
  /// episodes, or when there are more than 253 extra splits.
  static TrainingData load(const ExperimentConfig& config);
  /// The ground truths of the splits that have one.
  std::vector<const data::GroundTruth*> groundTruths() const;
};

/// The GloVe rows of dataset.embeddings as a [vocab, dim] tensor. Throws
/// std::invalid_argument when their shape is not model.vocab_size x
/// model.embedding_dim.
at::Tensor embeddingTensor(const ExperimentConfig& config);

}  // namespace vln::train
