#pragma once
// Settings of the candidate-waypoint predictor's training (trainer.task =
// waypoint_predictor, YAML section `waypoint:`; train/WaypointPretrainer.h).
// No LibTorch.

#include <string>

#include "common/Config.h"
#include "models/WaypointPredictorConfig.h"
#include "waypoint/WaypointTargets.h"

namespace vln::train {

struct WaypointPretrainConfig {
  std::string train_split = "train";
  std::string eval_split = "val_unseen";
  int headings_per_node = 4;
  int max_nodes_per_house = -1;
  int eval_seed = 1;
  int epochs = 20;
  int batch_size = 16;
  double lr = 1e-3;
  double weight_decay = 0.01;
  std::string loss = "mse";
  double target_scale = 10.0;
  int nms_max_candidates = 5;
  int nms_heading_radius = 7;
  int nms_distance_radius = 5;
  double nms_min_score = 0.0;
  std::string weights_out;
  models::WaypointPredictorConfig predictor;
  waypoint::WaypointTargetConfig targets;

  void visit(common::ConfigVisitor& v) {
    v.field("train_split", train_split,
            "Split whose houses' nav-graph nodes the predictor trains on");
    v.field("eval_split", eval_split,
            "Split whose houses it is evaluated on after every epoch");
    v.field("headings_per_node", headings_per_node,
            "Panoramas rendered per training node, each with its own random "
            "heading (an agent arrives from anywhere)",
            common::inRange(1, 1000));
    v.field("max_nodes_per_house", max_nodes_per_house,
            "Nodes per house, evenly spaced over the transferred ones (-1: "
            "all); both splits",
            common::atLeast(-1));
    v.field("eval_seed", eval_seed,
            "Seed of the evaluation nodes' headings, one per node as "
            "`vlnce-data waypoint-metrics --seed` draws them",
            common::atLeast(0));
    v.field("epochs", epochs, "Passes over the training panoramas",
            common::inRange(1, 100000));
    v.field("batch_size", batch_size, "Panoramas per update",
            common::inRange(1, 100000));
    v.field("lr", lr, "AdamW learning rate", common::inRange(0.0, 1.0));
    v.field("weight_decay", weight_decay, "AdamW weight decay",
            common::inRange(0.0, 10.0));
    v.choice("loss", loss, {"mse", "softmax"},
             "mse: Hong et al.'s squared error of the logits against the "
             "target scaled to target_scale; softmax: cross-entropy of the "
             "softmax over the 1440 cells against the normalised target");
    v.field("target_scale", target_scale,
            "Peak of the target heatmap for the mse loss (Hong et al.: 10)",
            common::inRange(1e-3, 1e3));
    v.field("nms_max_candidates", nms_max_candidates,
            "Candidates non-maximum suppression keeps at most (Hong et al.: 5)",
            common::inRange(1, 120));
    v.field("nms_heading_radius", nms_heading_radius,
            "Heading bins suppressed on each side of a pick (Hong et al.: 7)",
            common::inRange(0, 60));
    v.field("nms_distance_radius", nms_distance_radius,
            "Distance bins suppressed on each side of a pick (Hong et al.: 5)",
            common::inRange(0, 12));
    v.field("nms_min_score", nms_min_score,
            "Picks whose softmax probability is at or below this are dropped "
            "(Hong et al.: 0, always the maximum number)",
            common::inRange(0.0, 1.0));
    v.field("weights_out", weights_out,
            "Output file of the trained predictor (empty: "
            "<output.dir>/waypoint_predictor.pt)");
    v.section("predictor", predictor, "The predictor's network");
    v.section("targets", targets, "Target heatmaps from the nav-graph");
  }
  bool operator==(const WaypointPretrainConfig&) const = default;
};

}  // namespace vln::train
