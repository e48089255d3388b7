#include "train/TrainingData.h"

#include <spdlog/spdlog.h>
#include <torch/torch.h>

#include "common/Check.h"
#include "data/Glove.h"

namespace vln::train {

TrainingData TrainingData::load(const ExperimentConfig& config) {
  const std::filesystem::path root = config.dataset.data_path;
  TrainingData data;
  data.train = data::loadSplit(root, config.dataset.train_split,
                               config.dataset.max_train_episodes);
  VLN_CHECK_ARG(!data.train.episodes.empty(), "train: dataset.train_split '",
                config.dataset.train_split, "' under '", root.string(),
                "' has no episodes");
  spdlog::info("training split '{}': {} episodes{}", data.train.name,
               data.train.episodes.size(),
               data.train.groundTruth ? "" : " (no ground-truth file)");
  if (config.trainer.use_aug) {
    data.aug = std::make_unique<data::Split>(data::loadSplit(
        root, config.dataset.aug_split, config.dataset.max_aug_episodes));
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
        data::loadSplit(root, extraNames[k], /*cap=*/-1)));
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
  return data;
}

std::vector<const data::GroundTruth*> TrainingData::groundTruths() const {
  std::vector<const data::GroundTruth*> out = {train.groundTruth.get()};
  if (aug) out.push_back(aug->groundTruth.get());
  for (const auto& split : extra) out.push_back(split->groundTruth.get());
  return out;
}

torch::Tensor embeddingTensor(const ExperimentConfig& config) {
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
