#pragma once
// Procedural multi-room houses, deterministic by seed: typed rooms, walls
// with doorways, floors and ceilings, and furniture landmarks of named
// categories and colours with semantic labels. The stand-in for Matterport3D
// scans so that everything runs with no download.
//
// What a house guarantees (tested in tests/sim/HouseGeneratorTest.cpp):
//  - every room is reachable from every other through doorways (a spanning
//    tree plus a few loops; bathrooms, closets and laundry rooms are leaves
//    where the plan allows), and the walls are closed: from inside, every
//    ray hits a surface except through the optional floor hole;
//  - one living room and one kitchen per house (two or more rooms);
//  - objects lie inside their room, never overlap each other (bounds) or a
//    doorway's clear zone, and leave corridors of at least 0.6 m so that an
//    agent reaches every doorway and gets next to every object;
//  - an object's colour name is the colour of its largest visible part,
//    with RGB as people name it (see houseColorNames()).

#include <cstdint>
#include <string>
#include <vector>

#include "common/Config.h"
#include "sim/Mesh.h"

namespace vln::sim {

/// House generation parameters.
struct HouseConfig {
  int min_rooms = 5;  ///< rooms per house, inclusive range
  int max_rooms = 9;
  float min_room_size =
      2.6f;  ///< shortest room side (hallways excepted), metres
  float max_room_size =
      6.0f;                  ///< longest room side (hallways excepted), metres
  float wall_height = 2.7f;  ///< floor to ceiling, metres
  float wall_thickness = 0.12f;    ///< metres
  float door_width = 1.0f;         ///< clear doorway width, metres
  float furniture_density = 1.0f;  ///< multiplies objects per room
  float floor_hole_probability =
      0.15f;  ///< chance a house gets a hole in a floor (as scans do)
  float texture_detail =
      1.0f;  ///< strength of procedural surface patterns (0 = flat colours)

  void visit(common::ConfigVisitor& v) {
    v.field("min_rooms", min_rooms, "Fewest rooms per house",
            common::inRange(1, 40));
    v.field("max_rooms", max_rooms, "Most rooms per house",
            common::inRange(1, 40));
    v.field("min_room_size", min_room_size, "Shortest room side (m)",
            common::inRange(1.5, 20));
    v.field("max_room_size", max_room_size, "Longest room side (m)",
            common::inRange(1.5, 30));
    v.field("wall_height", wall_height, "Floor to ceiling (m)",
            common::inRange(2.0, 6.0));
    v.field("wall_thickness", wall_thickness, "Wall thickness (m)",
            common::inRange(0.02, 0.5));
    v.field("door_width", door_width, "Doorway clear width (m)",
            common::inRange(0.6, 3.0));
    v.field("furniture_density", furniture_density,
            "Objects per room multiplier", common::inRange(0.0, 5.0));
    v.field("floor_hole_probability", floor_hole_probability,
            "Chance of a hole in a floor", common::inRange(0.0, 1.0));
    v.field("texture_detail", texture_detail, "Surface pattern strength",
            common::inRange(0.0, 1.0));
  }
  void validate() const {
    VLN_CHECK_ARG(min_rooms <= max_rooms, "HouseConfig: min_rooms (", min_rooms,
                  ") exceeds max_rooms (", max_rooms, ")");
    VLN_CHECK_ARG(min_room_size <= max_room_size,
                  "HouseConfig: min_room_size exceeds max_room_size");
  }
  bool operator==(const HouseConfig&) const = default;
};

/// A generated house: triangles (lighting baked into vertex colours) and its
/// semantic annotations.
///
/// Frames and layout: world frame (+Y up, metres), floor at y = 0. Room
/// footprints run to the wall centre lines, so they tile the house outline.
/// Doorway centres lie on the wall centre line at floor height. Object ids
/// are 0..n-1; every triangle of object i has triangle_object == i, all
/// other triangles -1. Materials are one per surface finish ("plain",
/// "wood_floor", "tiles", "carpet", "wallpaper", "plaster", "wood",
/// "fabric"); uvs are world coordinates divided by each finish's repeat
/// size, so textures need REPEAT wrapping. With texture_detail == 0 the
/// mesh has no textures and no uvs.
struct House {
  std::string name;
  TriangleMesh mesh;
  SceneSemantics semantics;
  /// Missing floor patches (as scans have), (x, z) metres; at most one.
  std::vector<Eigen::AlignedBox2f> floor_holes;
};

/// A doorway's clear zone is kept free of furniture and floor holes: the
/// opening widened by this on each side, metres.
inline constexpr float kDoorwayClearMargin = 0.2f;
/// ... and this deep on both sides of the wall centre line, metres.
inline constexpr float kDoorwayClearDepth = 1.0f;

/// The clear zone of `door` in the horizontal plane ((x, z), metres).
Eigen::AlignedBox2f doorwayClearZone(const Doorway& door);

/// Generates house `seed` (named `name`, or "house_<seed>"). Equal seeds and
/// configs give bit-identical houses on every machine and compiler: the
/// generator uses its own PCG32 generator (no std:: distributions, whose
/// output is unspecified) and IEEE-exact float operations only. Throws
/// std::invalid_argument for configs out of bounds or without a possible
/// plan (e.g. doors wider than rooms).
House generateHouse(uint64_t seed, const HouseConfig& config,
                    const std::string& name = "");

/// Room types the generator uses, in a fixed order: living room, kitchen,
/// dining room, bedroom, bathroom, hallway, office, laundry room, closet.
const std::vector<std::string>& houseRoomTypes();
/// Object categories the generator uses, in a fixed order (29, from "bed"
/// to "window"; windows are closed panes on outside walls).
const std::vector<std::string>& houseObjectCategories();
/// Colour names the generator uses, in a fixed order: red, orange, yellow,
/// green, blue, purple, pink, brown, wooden, white, grey, black.
const std::vector<std::string>& houseColorNames();

}  // namespace vln::sim
