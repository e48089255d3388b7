#pragma once
// Where a run's episodes come from (YAML section `dataset:`). Paths follow
// the public R2R_VLNCE layout: <data_path>/<split>/<split>.json.gz with
// <split>_gt.json.gz beside it, and the GloVe rows in embeddings.json.gz;
// or, with format: rxr, RxR_VLNCE_v0's (RxrEpisodes.h): per role
// <data_path>/<split>/<split>_{role}.json.gz and _gt.json.gz, filtered by
// rxr_filter, and the instructions' text features under
// text_features_dir (RxrTextFeatures.h).

#include <filesystem>
#include <string>
#include <vector>

#include "common/Config.h"
#include "data/RxrEpisodes.h"

namespace vln::data {

struct DatasetConfig {
  std::string format = "r2r";
  std::string data_path = "data/datasets/procedural";
  std::string embeddings;
  std::string train_split = "train";
  std::string aug_split = "train_aug";
  std::vector<std::string> extra_train_splits;
  int max_train_episodes = -1;
  int max_aug_episodes = -1;
  int max_instruction_length = 200;
  RxrFilterConfig rxr_filter;
  std::string text_features_dir;

  void visit(common::ConfigVisitor& v) {
    v.choice("format", format, {"r2r", "rxr"},
             "Layout of the episode files: r2r (R2R_VLNCE, <split>.json.gz) "
             "or rxr (RxR_VLNCE_v0, <split>_{role}.json.gz per role of "
             "rxr_filter; docs/rxr.md)");
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
    v.section("rxr_filter", rxr_filter,
              "format rxr: the roles, languages and episode ids read "
              "(VLN-CE's DATASET.ROLES, LANGUAGES, EPISODES_ALLOWED)");
    v.field("text_features_dir", text_features_dir,
            "format rxr: the folder of rxr_{split}/{instruction_id:06}_"
            "{lang}_text_features.npz, read by models with "
            "model.instruction_features: rxr_text (empty: "
            "<data_path>/text_features)");
  }
  bool operator==(const DatasetConfig&) const = default;

  bool isRxr() const { return format == "rxr"; }

  /// The text features folder actually used.
  std::filesystem::path textFeaturesPath() const {
    return text_features_dir.empty()
               ? std::filesystem::path(data_path) / "text_features"
               : std::filesystem::path(text_features_dir);
  }

  /// The embeddings file actually used.
  std::filesystem::path embeddingsPath() const {
    return embeddings.empty()
               ? std::filesystem::path(data_path) / "embeddings.json.gz"
               : std::filesystem::path(embeddings);
  }
};

}  // namespace vln::data
