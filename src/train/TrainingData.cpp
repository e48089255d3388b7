#include "train/TrainingData.h"

#include <spdlog/spdlog.h>
#include <torch/torch.h>

#include <unordered_map>

#include "common/Check.h"
#include "common/Random.h"
#include "data/Glove.h"
#include "models/InstructionEncoder.h"
#include "train/FeatureStore.h"

namespace vln::train {
namespace {
// the trainer seed's stream of model.word_embeddings: random
constexpr uint64_t kRandomEmbeddingStream = 0x776f7264;  // "word"
}  // namespace

TrainingData TrainingData::load(const ExperimentConfig& config) {
  const std::filesystem::path root = config.dataset.data_path;
  TrainingData data;
  data.train =
      data::loadDatasetSplit(config.dataset, config.dataset.train_split,
                             config.dataset.max_train_episodes);
  VLN_CHECK_ARG(!data.train.episodes.empty(), "train: dataset.train_split '",
                config.dataset.train_split, "' under '", root.string(),
                "' has no episodes");
  spdlog::info("training split '{}': {} episodes{}", data.train.name,
               data.train.episodes.size(),
               data.train.groundTruth ? "" : " (no ground-truth file)");
  if (config.trainer.use_aug) {
    data.aug = std::make_unique<data::Split>(
        data::loadDatasetSplit(config.dataset, config.dataset.aug_split,
                               config.dataset.max_aug_episodes));
    spdlog::info("augmentation split '{}': {} episodes", data.aug->name,
                 data.aug->episodes.size());
  }
  for (const data::Episode& e : data.train.episodes) {
    data.pool.push_back(&e);
    data.sources.push_back(0);
  }
  if (data.aug)
    for (const data::Episode& e : data.aug->episodes) {
      data.pool.push_back(&e);
      data.sources.push_back(1);
    }
  const auto& extraNames = config.dataset.extra_train_splits;
  VLN_CHECK_ARG(extraNames.size() <= 253,
                "train: dataset.extra_train_splits "
                "has ",
                extraNames.size(), " splits, at most 253 are allowed");
  for (size_t k = 0; k < extraNames.size(); ++k) {
    data.extra.push_back(std::make_unique<data::Split>(
        data::loadDatasetSplit(config.dataset, extraNames[k], /*cap=*/-1)));
    const data::Split& split = *data.extra.back();
    VLN_CHECK_ARG(!split.episodes.empty(), "train: dataset.extra_train_splits[",
                  k, "] '", extraNames[k], "' under '", root.string(),
                  "' has no episodes");
    spdlog::info("extra training split '{}': {} episodes", split.name,
                 split.episodes.size());
    for (const data::Episode& e : split.episodes) {
      data.pool.push_back(&e);
      data.sources.push_back(static_cast<uint8_t>(2 + k));
    }
  }
  for (size_t i = 0; i < data.pool.size(); ++i)
    data.byKey.emplace(
        std::make_pair(data.sources[i],
                       static_cast<int64_t>(data.pool[i]->episode_id)),
        data.pool[i]);
  return data;
}

std::vector<const data::GroundTruth*> TrainingData::groundTruths() const {
  std::vector<const data::GroundTruth*> out = {train.groundTruth.get()};
  if (aug) out.push_back(aug->groundTruth.get());
  for (const auto& split : extra) out.push_back(split->groundTruth.get());
  return out;
}

const data::Split& TrainingData::sourceSplit(uint8_t source) const {
  if (source == 0) return train;
  if (source == 1) {
    VLN_ASSERT(aug != nullptr);
    return *aug;
  }
  VLN_ASSERT(static_cast<size_t>(source - 2) < extra.size());
  return *extra[static_cast<size_t>(source - 2)];
}

const data::Episode& TrainingData::episode(uint8_t source,
                                           int64_t episodeId) const {
  const auto it = byKey.find({source, episodeId});
  VLN_CHECK_ARG(it != byKey.end(),
                "TrainingData::episode(): the training "
                "pool has no episode ",
                episodeId, " of source ", static_cast<int>(source),
                " (a store of other splits?)");
  return *it->second;
}

rollout::InstructionFeatureSource TrainingData::textFeatureSource(
    const ExperimentConfig& config) const {
  // one reader per source split (the file path names the split)
  std::vector<rollout::InstructionFeatureSource> readers;
  const size_t sourcesCount = 2 + extra.size();
  for (size_t s = 0; s < sourcesCount; ++s)
    readers.push_back(s == 1 && !aug
                          ? rollout::InstructionFeatureSource()
                          : rollout::rxrTextFeatureSource(
                                config.dataset.textFeaturesPath(),
                                sourceSplit(static_cast<uint8_t>(s)).name,
                                config.model.text_feature_dim));
  auto sourceOf =
      std::make_shared<std::unordered_map<const data::Episode*, uint8_t>>();
  for (size_t i = 0; i < pool.size(); ++i)
    sourceOf->emplace(pool[i], sources[i]);
  return [readers = std::move(readers), sourceOf](const data::Episode& e) {
    const auto it = sourceOf->find(&e);
    VLN_ASSERT(it != sourceOf->end());  // only pool episodes are collected
    return readers[it->second](e);
  };
}

void TrainingData::requireTextFeatureFiles(
    const ExperimentConfig& config) const {
  for (uint8_t source = 0; source < 2 + extra.size(); ++source) {
    if (source == 1 && !aug) continue;
    std::vector<const data::Episode*> episodes;
    for (size_t i = 0; i < pool.size(); ++i)
      if (sources[i] == source) episodes.push_back(pool[i]);
    rollout::requireRxrTextFeatureFiles(config.dataset.textFeaturesPath(),
                                        sourceSplit(source).name, episodes);
  }
}

torch::Tensor TrainingData::batchTextFeatures(
    const ExperimentConfig& config, const FeatureStore& store,
    std::span<const int64_t> indices) const {
  std::vector<StoredEpisodeKey> keys;
  keys.reserve(indices.size());
  for (const int64_t i : indices) keys.push_back(store.key(i));
  return batchTextFeatures(config, keys);
}

torch::Tensor TrainingData::batchTextFeatures(
    const ExperimentConfig& config,
    std::span<const StoredEpisodeKey> keys) const {
  std::vector<torch::Tensor> rows;
  rows.reserve(keys.size());
  for (const StoredEpisodeKey& key : keys) {
    // a reader is a path and a split name: cheap to make per episode
    const rollout::InstructionFeatureSource reader =
        rollout::rxrTextFeatureSource(config.dataset.textFeaturesPath(),
                                      sourceSplit(key.source).name,
                                      config.model.text_feature_dim);
    rows.push_back(rollout::instructionFeatures(
        reader, episode(key.source, key.episode_id),
        config.model.text_feature_dim, config.dataset.max_instruction_length));
  }
  return rollout::batchInstructionFeatures(rows);
}

torch::Tensor embeddingTensor(const ExperimentConfig& config) {
  if (config.model.word_embeddings == models::WordEmbeddings::kRandom)
    return models::randomWordEmbeddings(
        config.model.vocab_size, config.model.embedding_dim,
        common::deriveSeed(static_cast<uint64_t>(config.trainer.seed),
                           kRandomEmbeddingStream));
  const std::filesystem::path file = config.dataset.embeddingsPath();
  data::EmbeddingMatrix matrix = data::readEmbeddingsJson(file);
  VLN_CHECK_ARG(matrix.rows == config.model.vocab_size &&
                    matrix.dim == config.model.embedding_dim,
                "train: the embeddings '", file.string(), "' are ", matrix.rows,
                " x ", matrix.dim,
                " but model.vocab_size x model.embedding_dim is ",
                config.model.vocab_size, " x ", config.model.embedding_dim,
                " (set the model to the vocabulary of dataset.data_path)");
  return torch::from_blob(matrix.values.data(), {matrix.rows, matrix.dim},
                          torch::kFloat32)
      .clone();
}

}  // namespace vln::train
