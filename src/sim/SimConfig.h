#pragma once
// Configuration of the simulator, one documented aggregate per concern. The
// YAML section `sim:` mirrors SimConfig and `task:` mirrors TaskConfig. Each
// field is documented once, by its description in visit(), which `train
// --dry-run` prints beside the key.

#include <string>

#include "common/Config.h"

namespace vln::sim {

/// Which axis of a mesh file points up. MP3D .glb (R2R_VLNCE) is Y-up; many
/// scanned .ply/.obj files are Z-up.
enum class UpAxis { kY, kZ };

/// How mesh files are brought into the world frame.
struct MeshLoadConfig {
  UpAxis up_axis = UpAxis::kY;
  float scale = 1.0f;

  void visit(common::ConfigVisitor& v) {
    v.enumeration("up_axis", up_axis, {{"y", UpAxis::kY}, {"z", UpAxis::kZ}},
                  "Up axis of scene files (MP3D .glb: y; many scanned "
                  ".ply/.obj: z)");
    v.field("scale", scale,
            "Multiplies every coordinate of a scene file (file units to "
            "metres)",
            common::inRange(1e-6, 1e6));
  }
  bool operator==(const MeshLoadConfig&) const = default;
};

/// Recast navmesh parameters. Defaults are Habitat-Sim's NavMeshSettings.
struct NavMeshConfig {
  float cell_size = 0.05f;
  float cell_height = 0.2f;
  float agent_height = 1.5f;
  float agent_radius = 0.1f;
  float agent_max_climb = 0.2f;
  float agent_max_slope = 45.0f;
  float region_min_size = 20.0f;  // Recast's minRegionArea is its square
  float region_merge_size = 20.0f;
  float edge_max_len = 12.0f;  // Recast takes it divided by cell_size
  float edge_max_error = 1.3f;
  int verts_per_poly = 6;
  float detail_sample_dist = 6.0f;
  float detail_sample_max_error = 1.0f;
  bool filter_low_hanging_obstacles = true;
  bool filter_ledge_spans = true;
  bool filter_walkable_low_height_spans = true;

  // The descriptions below are frozen: worldHouseName() hashes this
  // section's YAML, comments included, so a changed description would
  // rename every house of a generated world.
  void visit(common::ConfigVisitor& v) {
    v.field("cell_size", cell_size, "Voxel size in x and z (m)", common::inRange(0.005, 1.0));
    v.field("cell_height", cell_height, "Voxel size in y (m)", common::inRange(0.005, 1.0));
    v.field("agent_height", agent_height, "Agent cylinder height (m)", common::inRange(0.1, 5.0));
    v.field("agent_radius", agent_radius, "Agent cylinder radius (m)", common::inRange(0.0, 2.0));
    v.field("agent_max_climb", agent_max_climb, "Highest step the agent climbs (m)", common::inRange(0.0, 2.0));
    v.field("agent_max_slope", agent_max_slope, "Steepest walkable slope (degrees)", common::inRange(0.0, 89.0));
    v.field("region_min_size", region_min_size, "Smallest kept region (cells, sqrt)", common::atLeast(0));
    v.field("region_merge_size", region_merge_size, "Regions below this merge (cells, sqrt)", common::atLeast(0));
    v.field("edge_max_len", edge_max_len, "Longest contour edge (m)", common::atLeast(0));
    v.field("edge_max_error", edge_max_error, "Contour simplification error (cells)", common::atLeast(0));
    v.field("verts_per_poly", verts_per_poly, "Vertices per navmesh polygon", common::inRange(3, 6));
    v.field("detail_sample_dist", detail_sample_dist, "Detail mesh sample spacing (cells)", common::atLeast(0));
    v.field("detail_sample_max_error", detail_sample_max_error, "Detail mesh error (cells)", common::atLeast(0));
    v.field("filter_low_hanging_obstacles", filter_low_hanging_obstacles, "Recast low-hanging obstacle filter");
    v.field("filter_ledge_spans", filter_ledge_spans, "Recast ledge filter");
    v.field("filter_walkable_low_height_spans", filter_walkable_low_height_spans, "Recast low-height filter");
  }
  bool operator==(const NavMeshConfig&) const = default;
};

/// The agent's body and action space (LoCoBot-like, as in VLN-CE). The
/// defaults are R2R_VLNCE's; configs/rxr/task.yaml holds RxR_VLNCE's.
struct AgentConfig {
  float forward_step_size = 0.25f;
  float turn_angle = 15.0f;
  bool allow_sliding = true;
  /// RxR_VLNCE's action space: LOOK_UP (4) and LOOK_DOWN (5) after the four
  /// R2R actions (Habitat's action space "v1").
  bool look_actions = false;
  float tilt_angle = 30.0f;

  void visit(common::ConfigVisitor& v) {
    v.field("forward_step_size", forward_step_size, "MOVE_FORWARD distance (m)", common::inRange(0.01, 5.0));
    v.field("turn_angle", turn_angle, "TURN_LEFT/TURN_RIGHT angle (degrees)", common::inRange(0.1, 180.0));
    v.field("allow_sliding", allow_sliding,
            "Slide along obstacles instead of stopping (Habitat "
            "allow_sliding)");
    v.field("look_actions", look_actions,
            "Add LOOK_UP (4) and LOOK_DOWN (5), which pitch the cameras "
            "(RxR-Habitat's action space)");
    v.field("tilt_angle", tilt_angle,
            "LOOK_UP/LOOK_DOWN angle (degrees; Habitat TILT_ANGLE)",
            common::inRange(0.1, 180.0));
  }
  bool operator==(const AgentConfig&) const = default;
};

/// One egocentric camera.
struct CameraConfig {
  int width = 256;
  int height = 256;
  float hfov = 90.0f;
  float position_y = 1.25f;

  void visit(common::ConfigVisitor& v) {
    v.field("width", width, "Image width (pixels)", common::inRange(1, 4096));
    v.field("height", height, "Image height (pixels)", common::inRange(1, 4096));
    v.field("hfov", hfov, "Horizontal field of view (degrees)", common::inRange(1.0, 170.0));
    v.field("position_y", position_y,
            "Camera height above the agent's feet (m)",
            common::inRange(0.0, 5.0));
  }
  bool operator==(const CameraConfig&) const = default;
};

/// Depth camera: a camera plus clipping and normalisation of the output.
struct DepthCameraConfig {
  CameraConfig camera;
  float min_depth = 0.0f;
  float max_depth = 10.0f;
  bool normalize_depth = true;

  void visit(common::ConfigVisitor& v) {
    camera.visit(v);
    v.field("min_depth", min_depth,
            "Depth clip minimum: closer values read as this (m)",
            common::inRange(0.0, 100.0));
    v.field("max_depth", max_depth,
            "Depth clip maximum: farther values and misses read as this (m)",
            common::inRange(0.01, 1000.0));
    v.field("normalize_depth", normalize_depth,
            "Map depth from [min_depth, max_depth] to [0, 1]");
  }
  bool operator==(const DepthCameraConfig&) const = default;
};

/// Rendering backend. All produce the same images up to float rounding at
/// pixel centres on triangle edges (tested).
enum class RendererBackend { kEmbree, kOsMesa, kRaster };

/// The simulator: scenes, navmesh, agent and sensors.
struct SimConfig {
  std::string scenes_dir = "data/scene_datasets";
  MeshLoadConfig mesh;
  NavMeshConfig navmesh;
  AgentConfig agent;
  CameraConfig rgb{224, 224, 90.0f, 1.25f};
  DepthCameraConfig depth;
  RendererBackend renderer = RendererBackend::kEmbree;
  bool cache_navmesh = true;

  void visit(common::ConfigVisitor& v) {
    v.field("scenes_dir", scenes_dir, "Directory that scene ids are relative to");
    v.section("mesh", mesh, "Scene file import");
    v.section("navmesh", navmesh, "Navmesh build parameters (Habitat defaults)");
    v.section("agent", agent, "Agent actions");
    v.section("rgb", rgb, "RGB camera");
    v.section("depth", depth, "Depth camera");
    v.enumeration("renderer", renderer,
                  {{"embree", RendererBackend::kEmbree},
                   {"osmesa", RendererBackend::kOsMesa},
                   {"raster", RendererBackend::kRaster}},
                  "Rendering backend: embree (ray casting), osmesa (OpenGL) "
                  "or raster (the CPU rasteriser); all render the same "
                  "images");
    v.field("cache_navmesh", cache_navmesh,
            "Save built navmeshes as <scene>.navmesh beside the scene file "
            "and load them from there");
  }
  bool operator==(const SimConfig&) const = default;
};

/// Episode rules of the VLN-CE task.
struct TaskConfig {
  int max_episode_steps = 500;
  float success_distance = 3.0f;
  float follower_goal_radius = 0.5f;

  void visit(common::ConfigVisitor& v) {
    v.field("max_episode_steps", max_episode_steps,
            "Action limit per episode; an episode ends unsuccessfully after "
            "this many actions",
            common::inRange(1, 100000));
    v.field("success_distance", success_distance,
            "STOP within this geodesic distance of the goal succeeds (m)",
            common::inRange(0.01, 100.0));
    v.field("follower_goal_radius", follower_goal_radius,
            "The oracle follower stops within this distance of a waypoint "
            "(m)",
            common::inRange(0.01, 10.0));
  }
  bool operator==(const TaskConfig&) const = default;
};

}  // namespace vln::sim
