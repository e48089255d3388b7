#pragma once
// Architecture of the candidate-waypoint predictor (models/
// WaypointPredictor.h; YAML section `waypoint.predictor:`). LibTorch stays
// out of this header so that train::ExperimentConfig can embed it cheaply.

#include "common/Check.h"
#include "common/Config.h"

namespace vln::models {

/// A small post-norm transformer over the panorama's view tokens, after
/// Hong et al.'s TRM_net (2 layers, attention to one neighbour on each
/// side), at CPU width.
struct WaypointPredictorConfig {
  int hidden_size = 128;
  int layers = 2;
  int heads = 4;
  int ff_size = 256;
  /// Views a token attends to on each side (circular); -1: all views.
  int neighbors = 1;
  double dropout = 0.1;
  /// Read the RGB views' features besides depth (when the model has RGB).
  bool rgb = true;

  void visit(common::ConfigVisitor& v) {
    v.field("hidden_size", hidden_size,
            "Width of a view token and of the transformer layers",
            common::inRange(8, 4096));
    v.field("layers", layers, "Transformer layers over the view tokens",
            common::inRange(1, 48));
    v.field("heads", heads,
            "Attention heads per layer (hidden_size must be a multiple)",
            common::inRange(1, 64));
    v.field("ff_size", ff_size, "Hidden width of each layer's feed-forward",
            common::inRange(8, 16384));
    v.field("neighbors", neighbors,
            "Views a token attends to on each side, wrapping around the "
            "circle (Hong et al.: 1); -1 attends to every view",
            common::inRange(-1, 180));
    v.field("dropout", dropout, "Dropout while training (0: none)",
            common::inRange(0.0, 0.9));
    v.field("rgb", rgb,
            "Read the RGB views' features besides the depth views' (when "
            "the model has RGB: model.no_rgb false); false: depth alone, "
            "whatever the agent reads. The agent's config must say what the "
            "predictor was trained with");
  }
  /// Throws std::invalid_argument naming `where` when hidden_size is not a
  /// multiple of heads.
  void validate(const char* where) const {
    VLN_CHECK_ARG(hidden_size % heads == 0, where, ".hidden_size (",
                  hidden_size, ") must be a multiple of heads (", heads, ")");
  }
  bool operator==(const WaypointPredictorConfig&) const = default;
};

}  // namespace vln::models
