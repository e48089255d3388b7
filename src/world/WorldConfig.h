#pragma once
// Configuration of the embedded default world: procedural houses, their R2R
// style nav-graphs, the paper's Section 3.2 transfer of nav-graph
// trajectories to the continuous scene, generated instructions and the
// R2R-like splits. One aggregate per stage; configs/world/default.yaml
// mirrors WorldConfig key for key. Distances are metres, angles degrees.
//
// Every stage draws through common/Random.h only, so the world comes out
// byte-identical on every platform.

#include <cstdint>
#include <string>

#include "common/Check.h"
#include "common/Config.h"
#include "data/GloveFitConfig.h"
#include "data/TransferConfig.h"
#include "sim/SimConfig.h"
#include "world/HouseConfig.h"

namespace vln::world {

// =========================================================================
// stages
// =========================================================================

/// Where the panorama nodes of a house go and which pairs are joined.
struct NavGraphBuildConfig {
  float node_spacing = 2.1f;
  float spacing_jitter = 0.35f;
  float wall_margin = 0.55f;
  float min_node_separation = 1.1f;
  float min_camera_height = 1.2f;
  float max_camera_height = 1.6f;
  float doorway_node_probability = 0.6f;
  float object_clearance = 0.1f;
  float object_clearance_spread = 0.4f;
  float furniture_node_probability = 0.2f;
  float flat_object_min_area = 0.7f;
  float flat_object_max_height = 1.15f;
  float hole_node_probability = 0.7f;
  float max_edge_length = 3.75f;
  float edge_drop_probability = 0.1f;

  void visit(common::ConfigVisitor& v) {
    v.field("node_spacing", node_spacing,
            "Grid step of nodes inside a room (m)", common::inRange(0.5, 10.0));
    v.field("spacing_jitter", spacing_jitter,
            "Uniform jitter of each grid node, either way (m)",
            common::inRange(0.0, 2.0));
    v.field("wall_margin", wall_margin, "Distance of nodes from room walls (m)",
            common::inRange(0.0, 3.0));
    v.field("min_node_separation", min_node_separation,
            "Closer nodes are merged (m)", common::inRange(0.0, 5.0));
    v.field("min_camera_height", min_camera_height,
            "Lowest tripod camera height above the floor (m)",
            common::inRange(0.2, 3.0));
    v.field("max_camera_height", max_camera_height,
            "Highest tripod camera height above the floor (m)",
            common::inRange(0.2, 3.0));
    v.field("doorway_node_probability", doorway_node_probability,
            "Chance a doorway gets a node", common::inRange(0.0, 1.0));
    v.field("object_clearance", object_clearance,
            "Nodes closer than this to furniture are pushed out, to a gap "
            "drawn uniformly from [object_clearance, object_clearance + "
            "object_clearance_spread] (m)",
            common::inRange(0.0, 2.0));
    v.field("object_clearance_spread", object_clearance_spread,
            "Pushed nodes keep a gap up to this much larger than "
            "object_clearance, so tripods end up at varied distances (m)",
            common::inRange(0.0, 2.0));
    v.field("furniture_node_probability", furniture_node_probability,
            "Chance a node over a large flat object (table, counter, bed top) "
            "stays there, as R2R tripods over tables appear in the scans",
            common::inRange(0.0, 1.0));
    v.field("flat_object_min_area", flat_object_min_area,
            "Footprint of a large flat object (m^2)",
            common::inRange(0.0, 100.0));
    v.field("flat_object_max_height", flat_object_max_height,
            "Highest top of a large flat object above the floor (m)",
            common::inRange(0.1, 3.0));
    v.field("hole_node_probability", hole_node_probability,
            "Chance a floor hole gets a node above it",
            common::inRange(0.0, 1.0));
    v.field("max_edge_length", max_edge_length,
            "Horizontal length of the longest edge (m)",
            common::inRange(0.5, 20.0));
    v.field("edge_drop_probability", edge_drop_probability,
            "Chance a visible pair within reach is left unconnected, as "
            "annotators pruned redundant edges",
            common::inRange(0.0, 1.0));
  }
  void validate() const {
    VLN_CHECK_ARG(min_camera_height <= max_camera_height,
                  "NavGraphBuildConfig: min_camera_height (", min_camera_height,
                  ") exceeds max_camera_height (", max_camera_height, ")");
  }
  bool operator==(const NavGraphBuildConfig&) const = default;
};

/// How the reconstructed scene differs from what the panoramas saw. The
/// paper traces most non-navigable trajectories to such differences: doors
/// closed and objects (chairs) moved between captures, so that the mesh
/// blocks a path the nav-graph's annotators connected, or covers a node.
/// The nav-graph is placed in the house as captured; these changes are then
/// made to the scene that agents move in.
struct ReconstructionConfig {
  float closed_door_probability = 0.04f;
  float moved_object_probability = 0.02f;
  float moved_object_offset = 0.3f;

  void visit(common::ConfigVisitor& v) {
    v.field("closed_door_probability", closed_door_probability,
            "Chance an interior doorway is closed in the scene",
            common::inRange(0.0, 1.0));
    v.field("moved_object_probability", moved_object_probability,
            "Chance per nav-graph node that a movable object ends up on it",
            common::inRange(0.0, 1.0));
    v.field("moved_object_offset", moved_object_offset,
            "Largest horizontal offset of a moved object from its node (m)",
            common::inRange(0.0, 2.0));
  }
  bool operator==(const ReconstructionConfig&) const = default;
};

/// Which nav-graph shortest paths count as R2R-like trajectories. R2R
/// sampled shortest paths of at least 5 m with 4-6 edges (Anderson et al.
/// 2018); the VLN-CE paper reports 4-6 nodes on average.
struct TrajectoryConfig {
  int min_nodes = 4;
  int max_nodes = 7;
  float min_length = 5.0f;
  float max_length = 16.0f;

  void visit(common::ConfigVisitor& v) {
    v.field("min_nodes", min_nodes, "Fewest nodes per trajectory, inclusive",
            common::inRange(2, 100));
    v.field("max_nodes", max_nodes, "Most nodes per trajectory, inclusive",
            common::inRange(2, 100));
    v.field("min_length", min_length, "Shortest trajectory along its edges (m)",
            common::inRange(0.0, 1000.0));
    v.field("max_length", max_length, "Longest trajectory along its edges (m)",
            common::inRange(0.0, 1000.0));
  }
  void validate() const {
    VLN_CHECK_ARG(min_nodes <= max_nodes, "TrajectoryConfig: min_nodes (",
                  min_nodes, ") exceeds max_nodes (", max_nodes, ")");
    VLN_CHECK_ARG(min_length <= max_length, "TrajectoryConfig: min_length (",
                  min_length, ") exceeds max_length (", max_length, ")");
  }
  bool operator==(const TrajectoryConfig&) const = default;
};

/// Generated instructions.
struct InstructionConfig {
  int per_trajectory = 3;
  int aug_per_trajectory = 1;
  float landmark_distance = 2.2f;
  float stop_landmark_distance = 2.0f;
  float detail = 0.55f;
  float speaker_wrong_side = 0.15f;
  float speaker_wrong_color = 0.15f;
  float speaker_drop_landmark = 0.5f;

  void visit(common::ConfigVisitor& v) {
    v.field("per_trajectory", per_trajectory,
            "Instructions per trajectory (R2R: 3)", common::inRange(1, 20));
    v.field("aug_per_trajectory", aug_per_trajectory,
            "Speaker instructions per train_aug trajectory",
            common::inRange(1, 20));
    v.field("landmark_distance", landmark_distance,
            "Objects within this of the path may be named (m)",
            common::inRange(0.1, 20.0));
    v.field("stop_landmark_distance", stop_landmark_distance,
            "The stop object is within this of the goal (m)",
            common::inRange(0.1, 20.0));
    v.field("detail", detail,
            "Chance of each optional detail (colour, second landmark)",
            common::inRange(0.0, 1.0));
    v.field("speaker_wrong_side", speaker_wrong_side,
            "Speaker style: chance of a flipped side",
            common::inRange(0.0, 1.0));
    v.field("speaker_wrong_color", speaker_wrong_color,
            "Speaker style: chance of a wrong colour",
            common::inRange(0.0, 1.0));
    v.field("speaker_drop_landmark", speaker_drop_landmark,
            "Speaker style: chance a landmark is dropped",
            common::inRange(0.0, 1.0));
  }
  bool operator==(const InstructionConfig&) const = default;
};

/// How houses and trajectories are divided into R2R's splits. R2R holds
/// out 11 of 90 scans for val_unseen and 18 for test.
struct SplitConfig {
  float val_unseen_fraction = 0.14f;
  float test_fraction = 0.14f;
  int train_per_house = 20;
  int val_seen_per_house = 2;
  int val_unseen_per_house = 15;
  int test_per_house = 15;
  int aug_per_house = 60;
  int extra_train_houses = 0;
  int extra_unseen_houses = 0;
  bool evaluation_sub_instructions = false;

  void visit(common::ConfigVisitor& v) {
    v.field("val_unseen_fraction", val_unseen_fraction,
            "Share of houses held out for val_unseen",
            common::inRange(0.0, 1.0));
    v.field("test_fraction", test_fraction, "Share of houses held out for test",
            common::inRange(0.0, 1.0));
    v.field("train_per_house", train_per_house,
            "Navigable train trajectories per train house",
            common::inRange(0, 100000));
    v.field("val_seen_per_house", val_seen_per_house,
            "New trajectories per train house for val_seen",
            common::inRange(0, 100000));
    v.field("val_unseen_per_house", val_unseen_per_house,
            "Trajectories per val_unseen house", common::inRange(0, 100000));
    v.field("test_per_house", test_per_house, "Trajectories per test house",
            common::inRange(0, 100000));
    v.field("aug_per_house", aug_per_house,
            "train_aug trajectories per train house",
            common::inRange(0, 100000));
    v.field("extra_train_houses", extra_train_houses,
            "More training data without touching the other splits: houses "
            "generated after the first `houses`, every one a train house "
            "whose train_per_house trajectories form the train_extra split "
            "(human-style instructions). The other splits, the vocabulary "
            "and GloVe stay those of the first `houses` houses (words outside "
            "that vocabulary become <unk>)",
            common::inRange(0, 100000));
    v.field("extra_unseen_houses", extra_unseen_houses,
            "More held-out houses, for evaluation only: houses numbered from "
            "1000000 on (never an extra train house), each with "
            "val_unseen_per_house trajectories (goals and ground truth "
            "published, as val_unseen's) forming the val_unseen_extra split. "
            "The other splits, the vocabulary and GloVe stay unchanged",
            common::inRange(0, 100000));
    v.field("evaluation_sub_instructions", evaluation_sub_instructions,
            "Also write <split>_sub_instructions.json.gz for val_seen, "
            "val_unseen and val_unseen_extra (not test), for diagnostics "
            "that tell an agent where along its instruction it is "
            "(waypoint_agent.leg_words_only); new files only, the splits' "
            "own files are unchanged");
  }
  void validate() const {
    VLN_CHECK_ARG(val_unseen_fraction + test_fraction < 1.0f,
                  "SplitConfig: val_unseen_fraction + test_fraction must leave "
                  "train houses, got ",
                  val_unseen_fraction + test_fraction);
  }
  bool operator==(const SplitConfig&) const = default;
};

/// The whole world: configs/world/default.yaml.
struct WorldConfig {
  int houses = 40;
  int64_t seed = 1;
  std::string scene_prefix = "procedural";
  HouseConfig house;
  sim::NavMeshConfig navmesh;
  sim::AgentConfig agent;
  NavGraphBuildConfig nav_graph;
  ReconstructionConfig reconstruction;
  TrajectoryConfig trajectories;
  data::TransferConfig transfer;
  InstructionConfig instructions;
  SplitConfig splits;
  data::GloveFitConfig glove{.dim = 50, .window = 10, .epochs = 15};

  void visit(common::ConfigVisitor& v) {
    v.field("houses", houses, "Number of procedural houses",
            common::inRange(1, 100000));
    v.field("seed", seed,
            "Master seed of the world; every house and stage derives from it");
    v.field("scene_prefix", scene_prefix,
            "Scene ids are <prefix>/<house>/<house>.glb");
    v.section("house", house, "Procedural house generation");
    v.section("navmesh", navmesh,
              "Navmesh build parameters (written beside each scene)");
    v.section("agent", agent, "Agent actions of the ground-truth follower");
    v.section("nav_graph", nav_graph, "Panorama nodes and edges");
    v.section("reconstruction", reconstruction,
              "Differences between the captured house and its scene");
    v.section("trajectories", trajectories, "R2R-like trajectory sampling");
    v.section("transfer", transfer, "Section 3.2 transfer and navigability");
    v.section("instructions", instructions, "Generated instructions");
    v.section("splits", splits, "Houses and trajectories per split");
    v.section("glove", glove, "GloVe fitted on the training instructions");
  }
  void validate() const {
    house.validate();
    nav_graph.validate();
    trajectories.validate();
    splits.validate();
    VLN_CHECK_ARG(!scene_prefix.empty() &&
                      scene_prefix.find("..") == std::string::npos &&
                      scene_prefix.front() != '/',
                  "WorldConfig: scene_prefix must be a relative directory "
                  "name, got '",
                  scene_prefix, "'");
    VLN_CHECK_ARG(glove.threads == 1,
                  "WorldConfig: glove.threads must be 1 so that the world is "
                  "deterministic, got ",
                  glove.threads);
  }
  bool operator==(const WorldConfig&) const = default;
};

}  // namespace vln::world
