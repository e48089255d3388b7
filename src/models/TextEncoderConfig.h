#pragma once
// Architecture of the contextual text encoder (models/TextFeatureEncoder.h)
// that stands in for the BERT whose features RxR ships (YAML section
// `pretrain.text.encoder:`). LibTorch stays out of this header so that
// train::ExperimentConfig can embed it cheaply.

#include <string>

#include "common/Check.h"
#include "common/Config.h"

namespace vln::models {

/// Sizes of the text encoder: a small pre-norm transformer of `layers`
/// layers of width `hidden_size`, projected to `output_dim` feature columns.
struct TextEncoderConfig {
  int hidden_size = 128;
  int layers = 2;
  int heads = 4;
  int ff_size = 256;
  int output_dim = 768;
  int max_tokens = 512;
  double dropout = 0.1;

  void visit(common::ConfigVisitor& v) {
    v.field("hidden_size", hidden_size,
            "Width of the token embeddings and transformer layers",
            common::inRange(8, 4096));
    v.field("layers", layers, "Transformer encoder layers",
            common::inRange(1, 48));
    v.field("heads", heads,
            "Attention heads per layer (hidden_size must be a multiple)",
            common::inRange(1, 64));
    v.field("ff_size", ff_size, "Hidden width of each layer's feed-forward",
            common::inRange(8, 16384));
    v.field("output_dim", output_dim,
            "Columns of a feature row (RxR's BERT-base features: 768)",
            common::inRange(8, 4096));
    v.field("max_tokens", max_tokens,
            "Learned positions: tokens past this many are cut off (RxR's "
            "files hold at most 512)",
            common::inRange(8, 4096));
    v.field("dropout", dropout, "Dropout while training (0: none)",
            common::inRange(0.0, 0.9));
  }
  /// Throws std::invalid_argument when hidden_size is not a multiple of
  /// heads.
  void validate() const {
    VLN_CHECK_ARG(hidden_size % heads == 0,
                  "pretrain.text.encoder: "
                  "hidden_size (",
                  hidden_size, ") must be a multiple of heads (", heads, ")");
  }
  bool operator==(const TextEncoderConfig&) const = default;
};

}  // namespace vln::models
