#pragma once
// Parameters of the procedural house generator (HouseGenerator.h): section
// `house:` of a world config and of the pretraining config. Kept apart from
// the generator so that configs include no mesh types. Lengths are metres.

#include "common/Check.h"
#include "common/Config.h"

namespace vln::world {

/// House generation parameters.
struct HouseConfig {
  int min_rooms = 5;  // min_rooms to max_rooms, inclusive
  int max_rooms = 9;
  float min_room_size = 2.6f;  // room sides: hallways excepted
  float max_room_size = 6.0f;
  float wall_height = 2.7f;
  float wall_thickness = 0.12f;
  float door_width = 1.0f;
  float furniture_density = 1.0f;
  float floor_hole_probability = 0.15f;  // as scans have them
  float texture_detail = 1.0f;           // 0: flat colours

  // The descriptions below are frozen: worldHouseName() hashes this
  // section's YAML, comments included, so a changed description would
  // rename every house of a generated world.
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

}  // namespace vln::world
