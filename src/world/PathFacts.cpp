#include "world/PathFacts.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "common/Check.h"

namespace vln::world::instruction {

namespace {

// ===========================================================================
// geometry of a path
// ===========================================================================

// Paths are examined every kSampleStep metres.
constexpr float kSampleStep = 0.2f;
// Nothing is "passed" in the first or last metres: there the agent is
// starting or stopping, and R2R annotators describe those moments instead.
constexpr float kEndMargin = 0.6f;
// Room visits shorter than this are corners the path clips, not rooms it
// enters.
constexpr float kMinVisit = 0.6f;
// A room change within this of a doorway between the two rooms goes
// "through the doorway".
constexpr float kDoorNearTransition = 1.5f;
// The goal is "in the doorway" within this of a doorway centre.
constexpr float kDoorNearGoal = 0.8f;
// A landmark is on one side only when it is at least this far sideways and
// more sideways than ahead or behind.
constexpr float kMinLateral = 0.3f;
// Paths that cross a footprint (an edge drawn over a table) do not "pass" it.
constexpr float kMinPassDistance = 0.15f;
// A room change this close before the goal makes the goal "just inside".
constexpr float kJustEntered = 2.0f;
// Turns the same way at waypoints closer than this are described as one.
constexpr float kTurnMergeDistance = 2.0f;

Vec3f horizontal(const Vec3f& v) { return {v.x(), 0.0f, v.z()}; }

// Unit vector to the left of `heading` (counter-clockwise seen from above).
Vec3f leftOf(float heading) { return headingToForward(heading + 0.5f * kPi); }

}  // namespace

// Thresholds in degrees, from how R2R annotators describe turns: below 25
// they say nothing, up to 60 "slightly", up to 125 plain "left", up to 165
// "sharp left" (the doubling back after a doorway), beyond that "turn
// around".
TurnKind classifyTurn(float radians) {
  const float degrees = radToDeg(wrapAngle(radians));
  const float a = std::abs(degrees);
  const bool left = degrees > 0;
  if (a < 25.0f) return TurnKind::kStraight;
  if (a < 60.0f) return left ? TurnKind::kSlightLeft : TurnKind::kSlightRight;
  if (a < 125.0f) return left ? TurnKind::kLeft : TurnKind::kRight;
  if (a < 165.0f) return left ? TurnKind::kSharpLeft : TurnKind::kSharpRight;
  return TurnKind::kAround;
}

std::vector<Nameability> nameability(const sim::SceneSemantics& semantics) {
  std::vector<Nameability> result(semantics.objects.size());
  for (size_t i = 0; i < semantics.objects.size(); ++i) {
    const auto& o = semantics.objects[i];
    int sameCategory = 0;
    int sameColor = 0;
    for (const auto& other : semantics.objects) {
      if (other.room != o.room || other.category != o.category) continue;
      ++sameCategory;
      if (other.color == o.color) ++sameColor;
    }
    result[i].nameable = o.room >= 0 && (sameCategory == 1 || sameColor == 1);
    result[i].needs_color = sameCategory > 1;
  }
  return result;
}

PathFacts analyzePath(const sim::SceneSemantics& semantics,
                      const std::vector<Vec3f>& waypoints, float startHeading,
                      const InstructionConfig& config,
                      const std::vector<Nameability>& names) {
  PathFacts f;
  f.waypoints = waypoints;
  const size_t legs = waypoints.size() - 1;

  // legs, headings and samples
  for (size_t i = 0; i < legs; ++i) {
    const Vec3f d = horizontal(waypoints[i + 1] - waypoints[i]);
    f.heading.push_back(d.norm() > 1e-4f
                            ? forwardToHeading(d)
                            : (i > 0 ? f.heading.back() : startHeading));
    f.leg_start.push_back(f.total);
    const float length = d.norm();
    const int n =
        std::max(1, static_cast<int>(std::ceil(length / kSampleStep)));
    for (int k = 0; k < n; ++k) {
      const float t = static_cast<float>(k) / static_cast<float>(n);
      const Vec3f p = waypoints[i] + t * (waypoints[i + 1] - waypoints[i]);
      f.samples.push_back(
          {p, f.total + t * length, static_cast<int>(i), semantics.roomAt(p)});
    }
    f.total += length;
  }
  f.leg_start.push_back(f.total);
  f.samples.push_back({waypoints.back(), f.total, static_cast<int>(legs) - 1,
                       semantics.roomAt(waypoints.back())});

  // samples on a wall line belong to the room before them (or after, at
  // the very start)
  int known = -1;
  for (const Sample& s : f.samples)
    if (s.room >= 0) {
      known = s.room;
      break;
    }
  for (Sample& s : f.samples) {
    if (s.room < 0) s.room = known;
    known = s.room;
  }

  // room visits, without the corners the path merely clips
  std::vector<Visit> raw;
  for (const Sample& s : f.samples) {
    if (s.room < 0) continue;
    if (raw.empty() || raw.back().room != s.room)
      raw.push_back({s.room, s.s, s.s});
    raw.back().end = s.s;
  }
  for (size_t i = 0; i < raw.size(); ++i) {
    const bool inner = i > 0 && i + 1 < raw.size();
    if (inner && raw[i].end - raw[i].begin < kMinVisit) continue;
    if (!f.visits.empty() && f.visits.back().room == raw[i].room) {
      f.visits.back().end = raw[i].end;
      continue;
    }
    f.visits.push_back(raw[i]);
  }
  for (size_t i = 1; i < f.visits.size(); ++i) {
    Transition t{f.visits[i - 1].room, f.visits[i].room, f.visits[i].begin,
                 false};
    Vec3f at = waypoints.back();
    for (const Sample& s : f.samples)
      if (s.s >= t.s) {
        at = s.p;
        break;
      }
    for (const auto& door : semantics.doors) {
      const bool joins = (door.room_a == t.from && door.room_b == t.to) ||
                         (door.room_a == t.to && door.room_b == t.from);
      if (joins && horizontalDistance(door.center, at) <= kDoorNearTransition)
        t.door = true;
    }
    f.transitions.push_back(t);
  }

  // turns: at the start relative to the agent, then at every waypoint
  // (two bends the same way in quick succession are one turn to a reader)
  f.initial = classifyTurn(f.heading.front() - startHeading);
  for (size_t i = 1; i < legs; ++i) {
    float angle = wrapAngle(f.heading[i] - f.heading[i - 1]);
    const size_t first = i;
    while (i + 1 < legs &&
           f.leg_start[i + 1] - f.leg_start[i] < kTurnMergeDistance) {
      const float next = wrapAngle(f.heading[i + 1] - f.heading[i]);
      if (classifyTurn(next) == TurnKind::kStraight ||
          (next > 0) != (angle > 0))
        break;
      angle += next;
      ++i;
    }
    const TurnKind kind = classifyTurn(angle);
    if (kind != TurnKind::kStraight)
      f.turns.push_back({static_cast<int>(first), f.leg_start[first], kind});
  }

  // landmarks passed (beside the path) or approached (ahead on a leg)
  for (size_t o = 0; o < semantics.objects.size(); ++o) {
    const auto& object = semantics.objects[o];
    if (!names[o].nameable) continue;
    float best = std::numeric_limits<float>::infinity();
    const Sample* closest = nullptr;
    for (const Sample& s : f.samples) {
      if (s.s < kEndMargin || s.s > f.total - kEndMargin ||
          s.room != object.room)
        continue;
      const float d = footprintDistance(object.bounds, s.p);
      if (d < best) {
        best = d;
        closest = &s;
      }
    }
    // the nearest approach must lie inside the path: at its ends the
    // landmark is behind the start or beyond the goal, not passed
    if (closest == nullptr || best > config.landmark_distance ||
        best < kMinPassDistance || closest->s < kEndMargin + kSampleStep ||
        closest->s > f.total - kEndMargin - kSampleStep)
      continue;
    const float h = f.heading[static_cast<size_t>(closest->leg)];
    const Vec3f d = horizontal(object.bounds.center() - closest->p);
    const float along = d.dot(headingToForward(h));
    const float lateral = d.dot(leftOf(h));
    if (std::abs(lateral) >= std::max(kMinLateral, std::abs(along))) {
      f.passes.push_back({static_cast<int>(o), closest->s, closest->leg,
                          lateral > 0 ? Side::kLeft : Side::kRight,
                          std::abs(lateral)});
    } else if (along > 0) {
      const Vec3f& legEnd = waypoints[static_cast<size_t>(closest->leg) + 1];
      if (footprintDistance(object.bounds, legEnd) <= config.landmark_distance)
        f.towards.push_back({static_cast<int>(o), closest->leg,
                             f.leg_start[static_cast<size_t>(closest->leg)]});
    }
  }
  std::stable_sort(f.passes.begin(), f.passes.end(),
                   [](const Pass& a, const Pass& b) { return a.s < b.s; });

  // where to stop
  StopPlan& stop = f.stop;
  const Vec3f& goal = waypoints.back();
  stop.room = f.visits.empty() ? -1 : f.visits.back().room;
  float bestStop = std::numeric_limits<float>::infinity();
  for (size_t o = 0; o < semantics.objects.size(); ++o) {
    const auto& object = semantics.objects[o];
    if (!names[o].nameable || object.room != stop.room || stop.room < 0)
      continue;
    const float d = footprintDistance(object.bounds, goal);
    if (d <= config.stop_landmark_distance && d < bestStop) {
      bestStop = d;
      stop.object = static_cast<int>(o);
    }
  }
  if (stop.object >= 0) {
    const auto& object = semantics.objects[static_cast<size_t>(stop.object)];
    const float h = f.heading.back();
    const Vec3f d = horizontal(object.bounds.center() - goal);
    const float along = d.dot(headingToForward(h));
    const float lateral = d.dot(leftOf(h));
    stop.ahead = along > std::abs(lateral);
    if (std::abs(lateral) >= std::max(kMinLateral, std::abs(along)))
      stop.side = lateral > 0 ? Side::kLeft : Side::kRight;
  }
  for (const auto& door : semantics.doors)
    if (horizontalDistance(door.center, goal) <= kDoorNearGoal)
      stop.door = true;
  if (stop.room >= 0) {
    const auto& room = semantics.rooms[static_cast<size_t>(stop.room)];
    const Vec2f center = room.footprint.center();
    stop.near_center = (Vec2f(goal.x(), goal.z()) - center).norm() <=
                       0.25f * room.footprint.sizes().minCoeff();
  }
  stop.just_entered = !f.transitions.empty() &&
                      f.total - f.transitions.back().s <= kJustEntered;
  return f;
}

}  // namespace vln::world::instruction
