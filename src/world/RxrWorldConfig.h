#pragma once
// Configuration of the embedded RxR split (issue 17, "with no download"):
// longer, non-shortest walks through the houses of the default world, with
// timed instructions in RxR_VLNCE_v0's layout, for the RxR-Habitat agent.
// configs/world/rxr.yaml mirrors RxrWorldConfig key for key. Distances are
// metres, angles degrees, times seconds.
//
// The houses are those of `world` (a WorldConfig: with the defaults, the
// default world's houses, scene ids and house roles), so the RxR split
// shares scenes with the R2R split and holds out the same val_unseen and
// test houses. `navmesh` and `agent` are the RxR agent's
// (configs/rxr/task.yaml): the nodes are transferred to, and the ground
// truth is followed on, the navmesh of that agent.

#include <cstdint>
#include <string>

#include "common/Check.h"
#include "common/Config.h"
#include "sim/SimConfig.h"
#include "world/WorldConfig.h"

namespace vln::world {

/// Which nav-graph walks count as RxR-like paths: random walks that never
/// revisit a node, so not shortest paths in general. RxR's paths are about
/// twice R2R's (Ku et al. 2020: 14.9 m mean vs R2R's 9.4 m in the
/// nav-graph); R2R here: 4-7 nodes, 5-16 m.
struct RxrTrajectoryConfig {
  int min_nodes = 8;
  int max_nodes = 14;
  float min_length = 12.0f;
  float max_length = 40.0f;
  float min_goal_distance = 4.0f;
  float max_turn = 120.0f;
  int attempts_per_trajectory = 60;

  void visit(common::ConfigVisitor& v) {
    v.field("min_nodes", min_nodes, "Fewest nodes per walk, inclusive",
            common::inRange(2, 100));
    v.field("max_nodes", max_nodes, "Most nodes per walk, inclusive",
            common::inRange(2, 100));
    v.field("min_length", min_length, "Shortest walk along its edges (m)",
            common::inRange(0.0, 1000.0));
    v.field("max_length", max_length, "Longest walk along its edges (m)",
            common::inRange(0.0, 1000.0));
    v.field("min_goal_distance", min_goal_distance,
            "Straight distance from start to goal at least this, so that a "
            "walk does not end where it began (m)",
            common::inRange(0.0, 100.0));
    v.field("max_turn", max_turn,
            "Largest change of direction at a node (degrees); 180 allows "
            "walking straight back",
            common::inRange(0.0, 180.0));
    v.field("attempts_per_trajectory", attempts_per_trajectory,
            "Walks drawn per wanted trajectory before a house gives up",
            common::inRange(1, 100000));
  }
  void validate() const {
    VLN_CHECK_ARG(min_nodes <= max_nodes, "RxrTrajectoryConfig: min_nodes (",
                  min_nodes, ") exceeds max_nodes (", max_nodes, ")");
    VLN_CHECK_ARG(min_length <= max_length, "RxrTrajectoryConfig: min_length (",
                  min_length, ") exceeds max_length (", max_length, ")");
  }
  bool operator==(const RxrTrajectoryConfig&) const = default;
};

/// RxR-style annotations of a walk: the guide's and the follower's
/// instructions, their languages and per-word timing.
struct RxrInstructionConfig {
  int guide_per_trajectory = 2;
  int follower_per_trajectory = 1;
  float en_in_fraction = 0.5f;
  float guide_speed = 0.8f;
  float follower_speed = 0.6f;
  float node_pause = 1.5f;
  int annotators = 60;

  void visit(common::ConfigVisitor& v) {
    v.field("guide_per_trajectory", guide_per_trajectory,
            "Guide instructions per walk (RxR: one per language)",
            common::inRange(1, 20));
    v.field("follower_per_trajectory", follower_per_trajectory,
            "Follower instructions per walk: the same path, another "
            "instruction, its own timing",
            common::inRange(0, 20));
    v.field("en_in_fraction", en_in_fraction,
            "Chance an instruction is en-IN (light lexical differences from "
            "en-US)",
            common::inRange(0.0, 1.0));
    v.field("guide_speed", guide_speed,
            "Walking speed along the path that times the guide's words (m/s)",
            common::inRange(0.05, 10.0));
    v.field("follower_speed", follower_speed,
            "Walking speed that times the follower's words (m/s)",
            common::inRange(0.05, 10.0));
    v.field("node_pause", node_pause,
            "Time spent looking around at each intermediate node (s)",
            common::inRange(0.0, 60.0));
    v.field("annotators", annotators, "Distinct annotator ids drawn from",
            common::inRange(1, 1000000));
  }
  bool operator==(const RxrInstructionConfig&) const = default;
};

/// Walks per house and split; the house roles are the world's.
struct RxrSplitConfig {
  int train_per_house = 20;
  int val_seen_per_house = 3;
  int val_unseen_per_house = 12;
  int test_challenge_per_house = 12;

  void visit(common::ConfigVisitor& v) {
    v.field("train_per_house", train_per_house,
            "Navigable train walks per train house",
            common::inRange(0, 100000));
    v.field("val_seen_per_house", val_seen_per_house,
            "Further walks per train house for val_seen",
            common::inRange(0, 100000));
    v.field("val_unseen_per_house", val_unseen_per_house,
            "Walks per val_unseen house", common::inRange(0, 100000));
    v.field("test_challenge_per_house", test_challenge_per_house,
            "Walks per test house (test_challenge: no goals, no ground "
            "truth)",
            common::inRange(0, 100000));
  }
  bool operator==(const RxrSplitConfig&) const = default;
};

/// The whole RxR split: configs/world/rxr.yaml.
struct RxrWorldConfig {
  int64_t seed = 1;
  WorldConfig world;
  sim::NavMeshConfig navmesh{.agent_height = 0.88f, .agent_radius = 0.18f};
  sim::AgentConfig agent{.turn_angle = 30.0f, .allow_sliding = false};
  RxrTrajectoryConfig trajectories;
  RxrInstructionConfig instructions;
  RxrSplitConfig splits;

  void visit(common::ConfigVisitor& v) {
    v.field("seed", seed,
            "Seed of the walks and annotations (the houses follow "
            "world.seed)");
    v.section("world", world,
              "The houses: the default world's config (same seed and house "
              "settings = same scenes and house roles)");
    v.section("navmesh", navmesh,
              "Navmesh of the RxR agent (configs/rxr/task.yaml), written "
              "beside each scene as its agent variant");
    v.section("agent", agent,
              "Actions of the ground-truth follower: the RxR task's");
    v.section("trajectories", trajectories, "RxR-like walk sampling");
    v.section("instructions", instructions, "Guide and follower annotations");
    v.section("splits", splits, "Walks per house and split");
  }
  void validate() const {
    world.validate();
    trajectories.validate();
  }
  bool operator==(const RxrWorldConfig&) const = default;
};

}  // namespace vln::world
