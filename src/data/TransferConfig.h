#pragma once
// Parameters of the paper's Section 3.2 transfer (NodeTransfer.h): how
// panorama nodes are projected onto a navmesh and how a transferred
// trajectory is followed. Section `transfer:` of a world config
// (world/WorldConfig.h); the evaluator's nav-graph comparison uses the
// defaults. Distances are metres.

#include "common/Config.h"

namespace vln::data {

/// Section 3.2: projecting panorama nodes onto the navmesh and checking
/// that an agent can follow the transferred trajectory.
struct TransferConfig {
  float cast_distance = 2.0f;
  float cast_step = 0.05f;
  float max_displacement = 0.5f;
  float snap_vertical_extent = 0.25f;
  float adjusted_threshold = 0.01f;
  float min_floor_island_area = 4.0f;
  float follower_goal_radius = 0.5f;
  int leg_base_steps = 60;
  float leg_steps_per_meter = 8.0f;
  // Detours: such legs cross a doorway the reconstruction closed, and an
  // instruction saying "go through the door" would then supervise a walk
  // through other rooms.
  float max_leg_detour = 2.0f;

  void visit(common::ConfigVisitor& v) {
    v.field("cast_distance", cast_distance,
            "Length of the downward ray (m; paper: 2)",
            common::inRange(0.1, 10.0));
    v.field("cast_step", cast_step, "Spacing of projections along the ray (m)",
            common::inRange(0.005, 1.0));
    v.field("max_displacement", max_displacement,
            "Largest horizontal displacement of a valid node; farther nodes "
            "are invalid (m; paper: 0.5)",
            common::inRange(0.0, 5.0));
    v.field("snap_vertical_extent", snap_vertical_extent,
            "Vertical half extent of each projection box: a sample projects "
            "only to navmesh surfaces this close in height, which covers "
            "Recast's height quantisation (cell_height) (m)",
            common::inRange(0.01, 2.0));
    v.field("adjusted_threshold", adjusted_threshold,
            "Displacements above this count as adjusted in the statistics (m)",
            common::inRange(0.0, 1.0));
    v.field("min_floor_island_area", min_floor_island_area,
            "Navmesh islands at least this large are floors a ground agent "
            "may use, smaller ones are furniture tops; the largest island "
            "always counts (m^2)",
            common::inRange(0.0, 1e6));
    v.field("follower_goal_radius", follower_goal_radius,
            "Follower waypoint radius (m; paper: 0.5)",
            common::inRange(0.01, 10.0));
    v.field("leg_base_steps", leg_base_steps,
            "Step cap of one waypoint-to-waypoint leg: this many actions plus "
            "leg_steps_per_meter per metre of geodesic distance",
            common::inRange(1, 100000));
    v.field("leg_steps_per_meter", leg_steps_per_meter,
            "Step cap of one leg: actions per metre of geodesic distance, on "
            "top of leg_base_steps",
            common::inRange(0.0, 1000.0));
    v.field("max_leg_detour", max_leg_detour,
            "Beyond the paper: a leg whose navmesh geodesic exceeds this "
            "multiple of its straight length (at least 1 m) fails as a detour "
            "(0: no limit, as in the paper)",
            common::inRange(0.0, 1000.0));
  }
  bool operator==(const TransferConfig&) const = default;
};

}  // namespace vln::data
