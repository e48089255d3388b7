#pragma once
// Settings of the text encoder pretraining (trainer.task = text_mlm, YAML
// section `pretrain.text:`): the corpus, the masked-LM training and where
// the RxR-layout feature files go (train/TextPretrainer.h). No LibTorch.

#include <string>
#include <vector>

#include "common/Config.h"
#include "data/RxrEpisodes.h"
#include "models/TextEncoderConfig.h"

namespace vln::train {

struct TextPretrainConfig {
  std::string r2r_path;
  std::vector<std::string> r2r_train_splits = {"train", "train_aug"};
  std::vector<std::string> r2r_heldout_splits = {"val_seen", "val_unseen"};
  std::string rxr_path;
  data::RxrFilterConfig rxr_filter = {{"*"}, {"*"}, {"*"}};
  std::vector<std::string> rxr_train_splits = {"train"};
  std::vector<std::string> rxr_heldout_splits = {"val_seen", "val_unseen"};
  std::vector<std::string> feature_splits = {"train", "val_seen", "val_unseen"};
  std::string features_dir;
  std::string encoder_in;
  int min_count = 1;
  int epochs = 20;
  int batch_size = 32;
  double lr = 1e-3;
  double mask_probability = 0.15;
  models::TextEncoderConfig encoder;

  void visit(common::ConfigVisitor& v) {
    v.field("r2r_path", r2r_path,
            "Root of R2R-style episode splits whose instructions are corpus "
            "text (empty: dataset.data_path; \"none\": no R2R-style text)");
    v.field("r2r_train_splits", r2r_train_splits,
            "R2R-style splits the encoder and its vocabulary learn from");
    v.field("r2r_heldout_splits", r2r_heldout_splits,
            "R2R-style splits of the held-out masked-token accuracy (missing "
            "split files are skipped)");
    v.field("rxr_path", rxr_path,
            "Root of RxR_VLNCE-style splits ({split}/{split}_{role}.json.gz; "
            "empty: none): corpus text, and the instructions whose features "
            "are written");
    v.section("rxr_filter", rxr_filter,
              "Which RxR-style episodes count (roles, languages, ids)");
    v.field("rxr_train_splits", rxr_train_splits,
            "RxR-style splits the encoder and its vocabulary learn from");
    v.field("rxr_heldout_splits", rxr_heldout_splits,
            "RxR-style splits of the held-out masked-token accuracy");
    v.field("feature_splits", feature_splits,
            "RxR-style splits whose every instruction gets a feature file "
            "(with rxr_path)");
    v.field("features_dir", features_dir,
            "Where the feature files go, as rxr_{split}/{id:06}_{lang}_text_"
            "features.npz (empty: <rxr_path>/text_features, where the RxR "
            "reader looks)");
    v.field("encoder_in", encoder_in,
            "An encoder an earlier text_mlm run saved (pretrain.encoder_out, "
            "its .vocab.json beside it): no training, only the feature files "
            "of feature_splits are written with it (e.g. for a split added "
            "later); empty: train");
    v.field("min_count", min_count,
            "Training words seen fewer times map to <unk>",
            common::inRange(1, 1000000));
    v.field("epochs", epochs, "Passes over the training instructions",
            common::inRange(1, 100000));
    v.field("batch_size", batch_size, "Instructions per update",
            common::inRange(1, 100000));
    v.field("lr", lr, "Adam learning rate", common::inRange(0.0, 1.0));
    v.field("mask_probability", mask_probability,
            "Chance that a token is predicted (BERT: 0.15; in training 80% of "
            "them become <mask>, 10% a random word, 10% stay)",
            common::inRange(0.01, 1.0));
    v.section("encoder", encoder, "Text encoder architecture");
  }
  bool operator==(const TextPretrainConfig&) const = default;
};

}  // namespace vln::train
