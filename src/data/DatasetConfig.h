#pragma once
// Where a run's episodes come from (YAML section `dataset:`). Paths follow
// the public R2R_VLNCE layout: <data_path>/<split>/<split>.json.gz with
// <split>_gt.json.gz beside it, and the GloVe rows in embeddings.json.gz.

#include <filesystem>
#include <string>
#include <vector>

#include "common/Config.h"

namespace vln::data {

struct DatasetConfig {
  std::string data_path = "data/datasets/procedural";
  std::string embeddings;
  std::string train_split = "train";
  std::string aug_split = "train_aug";
  std::vector<std::string> extra_train_splits;
  int max_train_episodes = -1;
  int max_aug_episodes = -1;
  int max_instruction_length = 200;

  void visit(common::ConfigVisitor& v) {
    v.field("data_path", data_path,
            "Root directory of the episode splits (default: the embedded "
            "procedural world)");
    v.field("embeddings", embeddings,
            "GloVe embeddings.json.gz, rows in vocabulary order (empty: "
            "<data_path>/embeddings.json.gz)");
    v.field("train_split", train_split, "Training split name");
    v.field("aug_split", aug_split,
            "Augmentation split name, mixed into training when "
            "trainer.use_aug");
    v.field("extra_train_splits", extra_train_splits,
            "More splits trained on exactly like train_split (e.g. "
            "train_extra, written by the world's splits.extra_train_houses); "
            "they share its vocabulary and are not capped");
    v.field("max_train_episodes", max_train_episodes,
            "Cap on training episodes, for small runs (-1: all)",
            common::atLeast(-1));
    v.field("max_aug_episodes", max_aug_episodes,
            "Cap on augmentation episodes (-1: all)", common::atLeast(-1));
    v.field("max_instruction_length", max_instruction_length,
            "Instruction tokens fed to the encoder (R2R pads to 200): longer "
            "instructions are truncated, trailing PAD is trimmed per batch",
            common::inRange(1, 1000));
  }
  bool operator==(const DatasetConfig&) const = default;

  /// The embeddings file actually used.
  std::filesystem::path embeddingsPath() const {
    return embeddings.empty()
               ? std::filesystem::path(data_path) / "embeddings.json.gz"
               : std::filesystem::path(embeddings);
  }
};

}  // namespace vln::data
