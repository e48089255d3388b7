#pragma once
// Procedural multi-room houses, deterministic by seed: typed rooms, walls
// with doorways, floors and ceilings, and furniture landmarks of named
// categories and colours with semantic labels. The stand-in for Matterport3D
// scans so that everything runs with no download.
//
// What a house guarantees (tested in tests/world/HouseGeneratorTest.cpp):
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

#include "sim/Mesh.h"
#include "world/HouseConfig.h"

namespace vln::world {

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
  sim::TriangleMesh mesh;
  sim::SceneSemantics semantics;
  /// Missing floor patches (as scans have), (x, z) metres; at most one.
  std::vector<Eigen::AlignedBox2f> floor_holes;
};

/// A doorway's clear zone is kept free of furniture and floor holes: the
/// opening widened by this on each side, metres.
inline constexpr float kDoorwayClearMargin = 0.2f;
/// ... and this deep on both sides of the wall centre line, metres.
inline constexpr float kDoorwayClearDepth = 1.0f;

/// The clear zone of `door` in the horizontal plane ((x, z), metres).
Eigen::AlignedBox2f doorwayClearZone(const sim::Doorway& door);

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

}  // namespace vln::world
