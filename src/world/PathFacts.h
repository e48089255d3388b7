#pragma once
// Internal to the world module (InstructionGenerator.cpp): what an
// instruction can truthfully say about a path through a house. The path is
// sampled every 0.2 m; the facts are the rooms it visits, the transitions
// between them (through a doorway or not), the turns at its waypoints, the
// landmarks it passes on one side or walks towards, and where it stops.
// World frame (+Y up, metres); distances along the path are metres from the
// start, headings radians as in InstructionGenerator.h.

#include <vector>

#include "common/Math.h"
#include "sim/Mesh.h"
#include "world/InstructionGenerator.h"
#include "world/WorldConfig.h"

namespace vln::world::instruction {

/// "turn left at the X": X within this of the waypoint (metres).
inline constexpr float kTurnAnchorDistance = 1.2f;

/// How a turn is described (thresholds in classifyTurn()).
enum class TurnKind {
  kStraight,
  kSlightLeft,
  kSlightRight,
  kLeft,
  kRight,
  kSharpLeft,
  kSharpRight,
  kAround
};

/// The TurnKind of a change of heading by `radians`.
TurnKind classifyTurn(float radians);

/// A point of the path every 0.2 m.
struct Sample {
  Vec3f p;
  float s = 0.0f;  // distance along the path, metres
  int leg = 0;
  int room = -1;
};

/// A stretch of the path in one room.
struct Visit {
  int room = -1;
  float begin = 0.0f;
  float end = 0.0f;
};

/// A change of room along the path.
struct Transition {
  int from = -1;
  int to = -1;
  float s = 0.0f;
  bool door = false;
};

/// A turn at waypoint `waypoint`.
struct Turn {
  int waypoint = 0;
  float s = 0.0f;
  TurnKind kind = TurnKind::kStraight;
};

/// A landmark passed on one side.
struct Pass {
  int object = -1;  // index into semantics.objects
  float s = 0.0f;
  int leg = 0;
  Side side = Side::kNone;
  float lateral = 0.0f;  // metres, unsigned
};

/// A landmark ahead of the agent on leg `leg`.
struct Toward {
  int object = -1;
  int leg = 0;
  float s = 0.0f;
};

/// Where and how the path ends.
struct StopPlan {
  int room = -1;
  int object = -1;  // index into semantics.objects, or -1
  bool ahead = false;
  Side side = Side::kNone;
  bool door = false;
  bool near_center = false;
  bool just_entered = false;
};

/// Everything an instruction may say about one path.
struct PathFacts {
  std::vector<Vec3f> waypoints;
  std::vector<float> heading;    // per leg
  std::vector<float> leg_start;  // distance along the path of waypoint i
  float total = 0.0f;
  std::vector<Sample> samples;
  std::vector<Visit> visits;
  std::vector<Transition> transitions;
  TurnKind initial = TurnKind::kStraight;
  std::vector<Turn> turns;
  std::vector<Pass> passes;
  std::vector<Toward> towards;
  StopPlan stop;
};

/// Per object: can it be named unambiguously within its room, and does that
/// take its colour?
struct Nameability {
  bool nameable = false;
  bool needs_color = false;
};

/// Per object of `semantics`: whether it can be named unambiguously.
std::vector<Nameability> nameability(const sim::SceneSemantics& semantics);

/// The facts of the path through `waypoints` (at least two), starting with
/// heading `startHeading`; `names` from nameability().
PathFacts analyzePath(const sim::SceneSemantics& semantics,
                      const std::vector<Vec3f>& waypoints, float startHeading,
                      const InstructionConfig& config,
                      const std::vector<Nameability>& names);

}  // namespace vln::world::instruction
