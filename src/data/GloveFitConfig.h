#pragma once
// Hyper-parameters of GloVe fitting (GloveFit.h), on their own so that
// configs (the world's `glove:` section, `vlnce-data glove`) include no
// vector tables.

#include <cstdint>

#include "common/Config.h"

namespace vln::data {

/// Hyper-parameters of fitGlove(); defaults are the GloVe paper's.
struct GloveFitConfig {
  int dim = 50;
  int window = 10;
  int min_count = 1;
  double x_max = 100.0;
  double alpha = 0.75;
  double learning_rate = 0.05;
  int epochs = 25;
  double grad_clip = 100.0;
  int64_t seed = 1;
  int threads = 1;

  void visit(common::ConfigVisitor& v) {
    v.field("dim", dim, "Vector size", common::inRange(1, 4096));
    v.field("window", window,
            "Symmetric context window (words each side); a pair at "
            "distance d adds 1/d",
            common::inRange(1, 1000));
    v.field("min_count", min_count,
            "Words rarer than this are dropped from the corpus",
            common::atLeast(1));
    v.field("x_max", x_max, "Cutoff of the weighting f(x) = (x/x_max)^alpha",
            common::inRange(1e-6, 1e12));
    v.field("alpha", alpha, "Exponent of the weighting f(x)",
            common::inRange(0.0, 10.0));
    v.field("learning_rate", learning_rate, "AdaGrad initial learning rate",
            common::inRange(1e-9, 10.0));
    v.field("epochs", epochs, "Passes over the co-occurrence entries",
            common::inRange(1, 100000));
    v.field("grad_clip", grad_clip, "Per-component gradient clip (as glove.c)",
            common::inRange(1e-9, 1e12));
    v.field("seed", seed, "Initialisation and shuffling seed");
    v.field("threads", threads,
            "Training threads; > 1 is Hogwild and not deterministic",
            common::inRange(1, 256));
  }
  bool operator==(const GloveFitConfig&) const = default;
};

}  // namespace vln::data
