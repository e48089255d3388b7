#pragma once
// The episodes a VLN run learns from: dataset.train_split (capped by
// dataset.max_train_episodes), dataset.extra_train_splits and, with
// trainer.use_aug, dataset.aug_split (capped by dataset.max_aug_episodes);
// the pool that collection rounds draw from (train first, then aug, then the
// extra splits); the word embeddings the policy starts from, or, for
// model.instruction_features: rxr_text, where each episode's text features
// are (dataset.textFeaturesPath()/rxr_<its split>/...).

#include <ATen/core/Tensor.h>

#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <vector>

#include "data/Split.h"
#include "rollout/ObservationBatch.h"
#include "train/ExperimentConfig.h"

namespace vln::train {

class FeatureStore;
struct StoredEpisodeKey;

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
  /// Pool episode by (source, episode id), the feature store's key.
  std::map<std::pair<uint8_t, int64_t>, const data::Episode*> byKey;

  /// Loads the splits and logs their sizes. Throws std::invalid_argument
  /// naming dataset.train_split (or an extra split) when it has no
  /// episodes, or when there are more than 253 extra splits.
  static TrainingData load(const ExperimentConfig& config);
  /// The ground truths of the splits that have one.
  std::vector<const data::GroundTruth*> groundTruths() const;

  /// The split of pool source `source` (0 train, 1 aug, 2 + k extra k).
  const data::Split& sourceSplit(uint8_t source) const;
  /// The pool episode `episodeId` of source `source` (a store key);
  /// throws std::invalid_argument naming both when there is none (a store
  /// written from other splits).
  const data::Episode& episode(uint8_t source, int64_t episodeId) const;
  /// The text features of every pool episode (rollout::rxrTextFeatureSource()
  /// of its split under dataset.textFeaturesPath(), rows of width
  /// model.text_feature_dim), read from the file each time it is asked for:
  /// memory stays bounded however large the dataset. Only pool episodes
  /// (the pointers in `pool`) may be asked for. The source holds pointers
  /// into this object, which must outlive it.
  rollout::InstructionFeatureSource textFeatureSource(
      const ExperimentConfig& config) const;
  /// The text features of the stored episodes `indices` of `store`, in that
  /// order, zero-padded: [B, L, model.text_feature_dim] float32 (L capped
  /// at dataset.max_instruction_length), what EpisodeBatch::text_features
  /// holds for an rxr_text model.
  at::Tensor batchTextFeatures(const ExperimentConfig& config,
                               const FeatureStore& store,
                               std::span<const int64_t> indices) const;
  /// Throws, naming the missing files, unless every pool episode's RxR
  /// text-feature file exists: checked before anything is collected.
  void requireTextFeatureFiles(const ExperimentConfig& config) const;
  /// The same for episodes named by their keys (source and episode id), as
  /// the recollect trainer's batches, which have no store, carry them.
  at::Tensor batchTextFeatures(const ExperimentConfig& config,
                               std::span<const StoredEpisodeKey> keys) const;
};

/// The initial word embeddings as a [vocab, dim] tensor: with
/// model.word_embeddings glove the rows of dataset.embeddings (throws
/// std::invalid_argument when their shape is not model.vocab_size x
/// model.embedding_dim), with random models::randomWordEmbeddings() drawn
/// from trainer.seed.
at::Tensor embeddingTensor(const ExperimentConfig& config);

}  // namespace vln::train
