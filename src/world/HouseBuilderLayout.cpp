// Floor plans of procedural houses: room rectangles by recursive splitting
// (optionally around a hallway, optionally with a corner cut off), room
// types, and doorways forming a spanning tree plus a few loops.

// First of all includes: no FMA contraction (see the header).
#include "world/HouseFpContract.h"

#include <algorithm>
#include <map>
#include <numeric>
#include <optional>
#include <set>
#include <stdexcept>

#include "common/Check.h"
#include "common/Random.h"
#include "world/HouseBuilder.h"

namespace vln::world::house {

// ===========================================================================
// Rng
// ===========================================================================

Rng::Rng(uint64_t seed, uint64_t stream) {
  // PCG32 seeding: odd increment from the stream, state advanced once
  increment_ = (common::mixBits(stream ^ 0xDA3E39CB94B95BDBull) << 1u) | 1u;
  state_ = 0;
  next();
  state_ += common::mixBits(seed);
  next();
}

uint32_t Rng::next() {
  const uint64_t old = state_;
  state_ = old * 6364136223846793005ull + increment_;
  const auto xorshifted = static_cast<uint32_t>(((old >> 18u) ^ old) >> 27u);
  const auto rot = static_cast<uint32_t>(old >> 59u);
  return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
}

uint64_t Rng::next64() {
  const uint64_t high = next();
  return (high << 32) | next();
}

float Rng::uniform() {
  // 24 random bits scaled exactly into [0, 1)
  return static_cast<float>(next() >> 8) * (1.0f / 16777216.0f);
}

float Rng::uniform(float lo, float hi) { return lo + (hi - lo) * uniform(); }

int Rng::intIn(int lo, int hi) {
  VLN_ASSERT(lo <= hi);
  const uint32_t range = static_cast<uint32_t>(hi - lo) + 1u;
  if (range == 0) return static_cast<int>(next());  // full 32-bit range
  // Lemire-free rejection: reject the top partial bucket
  const uint32_t limit = UINT32_MAX - UINT32_MAX % range;
  uint32_t r;
  do {
    r = next();
  } while (r >= limit);
  return lo + static_cast<int>(r % range);
}

bool Rng::chance(float p) { return uniform() < p; }

Rng Rng::fork(uint64_t salt) {
  const uint64_t seed = next64();
  return Rng(seed, salt);
}

int Rng::weighted(const std::vector<float>& weights) {
  float total = 0.0f;
  for (float w : weights) total += w;
  VLN_ASSERT(total > 0.0f);
  float r = uniform() * total;
  for (size_t i = 0; i < weights.size(); ++i) {
    if (r < weights[i]) return static_cast<int>(i);
    r -= weights[i];
  }
  // rounding can leave r just above the last bucket
  for (int i = static_cast<int>(weights.size()) - 1; i >= 0; --i)
    if (weights[i] > 0.0f) return i;
  return 0;
}

// ===========================================================================
// floor plan
// ===========================================================================

namespace {

constexpr int kSnapCm = 10;         // room walls on a 10 cm grid
constexpr int kHallwayMinCm = 120;  // hallway widths, centre to centre
constexpr int kHallwayMaxCm = 170;
constexpr int kMaxAttempts = 60;

int snap(float cm) {
  return static_cast<int>(cm / kSnapCm + (cm >= 0 ? 0.5f : -0.5f)) * kSnapCm;
}

int toCm(float metres) { return static_cast<int>(metres * 100.0f + 0.5f); }

bool isLeafType(const std::string& type) {
  return type == "bathroom" || type == "closet" || type == "laundry room";
}

// Shared boundary of two cells: the wall line and the common interval.
struct Contact {
  bool along_x = true;
  int line = 0;
  int lo = 0, hi = 0;
  int length() const { return hi - lo; }
};

std::optional<Contact> contact(const RectCm& a, const RectCm& b) {
  // a vertical wall line x = const, overlapping in z
  if (a.x1 == b.x0 || b.x1 == a.x0) {
    const int lo = std::max(a.z0, b.z0), hi = std::min(a.z1, b.z1);
    if (hi > lo) return Contact{false, a.x1 == b.x0 ? a.x1 : a.x0, lo, hi};
  }
  // a horizontal wall line z = const, overlapping in x
  if (a.z1 == b.z0 || b.z1 == a.z0) {
    const int lo = std::max(a.x0, b.x0), hi = std::min(a.x1, b.x1);
    if (hi > lo) return Contact{true, a.z1 == b.z0 ? a.z1 : a.z0, lo, hi};
  }
  return std::nullopt;
}

class Planner {
 public:
  Planner(Rng& rng, const HouseConfig& config)
      : rng_(rng),
        config_(config),
        minSide_(snap(config.min_room_size * 100.0f)),
        maxSide_(std::max(minSide_, snap(config.max_room_size * 100.0f))),
        doorWidth_(toCm(config.door_width)),
        // jambs stay clear of corners: half a wall plus 15 cm of plaster
        doorMargin_(toCm(config.wall_thickness * 0.5f) + 15) {}

  FloorPlan run() {
    VLN_CHECK_ARG(doorWidth_ + 2 * doorMargin_ <= minSide_,
                  "HouseConfig: door_width (", config_.door_width,
                  " m) plus jambs does not fit in min_room_size (",
                  config_.min_room_size, " m)");
    const int rooms = rng_.intIn(config_.min_rooms, config_.max_rooms);
    for (int attempt = 0; attempt < kMaxAttempts; ++attempt) {
      std::vector<PlanRoom> cells = layout(rooms);
      if (static_cast<int>(cells.size()) != rooms) continue;
      if (!connectedByDoors(cells)) continue;
      FloorPlan plan;
      plan.rooms = std::move(cells);
      assignTypes(plan.rooms);
      placeDoors(plan);
      return plan;
    }
    throw std::invalid_argument(strCat(
        "HouseConfig: no floor plan with ", rooms, " rooms of sides ",
        config_.min_room_size, "..", config_.max_room_size, " m found in ",
        kMaxAttempts, " attempts; widen the room size range"));
  }

 private:
  // ---- room rectangles ---------------------------------------------------

  std::vector<PlanRoom> layout(int rooms) {
    // a corner room is cut off afterwards for L-shaped outlines
    const bool cutCorner = rooms >= 4 && rng_.chance(0.3f);
    const bool hallway = rooms >= 5 && rng_.chance(0.55f);
    const int cells = rooms + (cutCorner ? 1 : 0);
    std::vector<PlanRoom> out =
        hallway ? hallwayLayout(cells) : splitLayout(cells, {});
    if (out.empty()) return out;
    if (cutCorner && !removeCorner(out)) return {};
    // rooms (not hallways) must respect the size range
    for (const PlanRoom& room : out) {
      if (room.type == "hallway") continue;
      const int lo = std::min(room.cell.width(), room.cell.depth());
      const int hi = std::max(room.cell.width(), room.cell.depth());
      if (lo < minSide_ || hi > maxSide_) return {};
    }
    return out;
  }

  // Total house size for `rooms` rooms of random area.
  std::pair<int, int> houseSize(int rooms, float aspectLo, float aspectHi) {
    const float lo = static_cast<float>(minSide_) * 1.2f;
    const float hi = 0.5f * static_cast<float>(minSide_ + maxSide_);
    float area = 0.0f;
    for (int i = 0; i < rooms; ++i) {
      const float side = rng_.uniform(lo, hi);
      area += side * side * rng_.uniform(1.0f, 1.3f);
    }
    const float aspect = rng_.uniform(aspectLo, aspectHi);
    // width = sqrt(area * aspect), through sqrt only
    const float width = std::sqrt(area * aspect);
    return {snap(width), snap(area / width)};
  }

  // Recursive splitting of `region` (or a fresh house rectangle) into `count`
  // cells: always split the largest splittable cell across its long side.
  std::vector<PlanRoom> splitLayout(int count, std::optional<RectCm> region) {
    RectCm house;
    if (region) {
      house = *region;
    } else {
      const auto [w, d] = houseSize(count, 1.0f, 1.6f);
      house = {-snap(w / 2.0f), -snap(d / 2.0f), 0, 0};
      house.x1 = house.x0 + w;
      house.z1 = house.z0 + d;
    }
    std::vector<RectCm> cells{house};
    while (static_cast<int>(cells.size()) < count) {
      int best = -1;
      for (size_t i = 0; i < cells.size(); ++i) {
        const int longSide = std::max(cells[i].width(), cells[i].depth());
        if (longSide < 2 * minSide_) continue;
        if (best < 0 || cells[i].area() > cells[best].area())
          best = static_cast<int>(i);
      }
      if (best < 0) return {};
      const RectCm cell = cells[best];
      // split across the long side; near-square cells pick either way
      bool cutX = cell.width() >= cell.depth();
      const int shortSide = std::min(cell.width(), cell.depth());
      if (shortSide >= 2 * minSide_ && cell.width() * 4 < cell.depth() * 5 &&
          cell.depth() * 4 < cell.width() * 5)
        cutX = rng_.chance(0.5f);
      const int span = cutX ? cell.width() : cell.depth();
      const int origin = cutX ? cell.x0 : cell.z0;
      const int lo = origin + minSide_, hi = origin + span - minSide_;
      int at = snap(static_cast<float>(origin) +
                    rng_.uniform(0.3f, 0.7f) * static_cast<float>(span));
      at = std::clamp(at, lo, hi);
      RectCm a = cell, b = cell;
      if (cutX) {
        a.x1 = at;
        b.x0 = at;
      } else {
        a.z1 = at;
        b.z0 = at;
      }
      cells[best] = a;
      cells.push_back(b);
    }
    std::vector<PlanRoom> out;
    for (const RectCm& c : cells) out.push_back({"", c});
    return out;
  }

  // A hallway strip along x with rooms on both sides (split only across the
  // hallway so every room touches it), sometimes ending at an open block.
  std::vector<PlanRoom> hallwayLayout(int count) {
    const int hall = snap(rng_.uniform(kHallwayMinCm, kHallwayMaxCm));
    const int sideRooms = count - 1;
    int blockRooms = 0;
    if (sideRooms >= 5 && rng_.chance(0.5f)) blockRooms = rng_.intIn(1, 2);
    const int north = (sideRooms - blockRooms + 1) / 2;
    const int south = sideRooms - blockRooms - north;
    if (south < 1) return {};
    // side strips: depths within the room size range
    const int depthN =
        snap(rng_.uniform(static_cast<float>(minSide_),
                          std::min(maxSide_, minSide_ + 200) + 0.0f));
    const int depthS =
        snap(rng_.uniform(static_cast<float>(minSide_),
                          std::min(maxSide_, minSide_ + 200) + 0.0f));
    // length: enough for the busier side's rooms
    const int perRoom =
        snap(rng_.uniform(static_cast<float>(minSide_) * 1.1f,
                          0.5f * static_cast<float>(minSide_ + maxSide_)));
    const int length = perRoom * std::max(north, south);
    const int x0 = -snap(length / 2.0f);
    const int z0 = -snap((depthN + hall + depthS) / 2.0f);
    std::vector<PlanRoom> out;
    out.push_back(
        {"hallway", {x0, z0 + depthN, x0 + length, z0 + depthN + hall}});
    auto strip = [&](RectCm rect, int rooms) {
      // split only across x so each piece keeps the hallway edge
      std::vector<int> cuts{rect.x0};
      int remaining = rect.width();
      for (int i = rooms; i > 1; --i) {
        const int lo = minSide_, hi = remaining - (i - 1) * minSide_;
        int w = snap(static_cast<float>(remaining) / static_cast<float>(i) *
                     rng_.uniform(0.75f, 1.25f));
        w = std::clamp(w, lo, std::max(lo, hi));
        cuts.push_back(cuts.back() + w);
        remaining -= w;
      }
      cuts.push_back(rect.x1);
      for (size_t i = 0; i + 1 < cuts.size(); ++i)
        out.push_back({"", {cuts[i], rect.z0, cuts[i + 1], rect.z1}});
    };
    strip({x0, z0, x0 + length, z0 + depthN}, north);
    strip({x0, z0 + depthN + hall, x0 + length, z0 + depthN + hall + depthS},
          south);
    if (blockRooms > 0) {
      // an open block across the hallway's east end
      const int blockWidth = snap(rng_.uniform(static_cast<float>(minSide_),
                                               static_cast<float>(maxSide_)));
      const RectCm block{x0 + length, z0, x0 + length + blockWidth,
                         z0 + depthN + hall + depthS};
      for (PlanRoom& room : splitLayout(blockRooms, block)) out.push_back(room);
      if (static_cast<int>(out.size()) != count) return {};
    }
    return out;
  }

  // Removes a room that holds a corner of the house's bounding box, when the
  // rest stays door-connected.
  bool removeCorner(std::vector<PlanRoom>& rooms) {
    RectCm bounds = rooms[0].cell;
    for (const PlanRoom& r : rooms) {
      bounds.x0 = std::min(bounds.x0, r.cell.x0);
      bounds.z0 = std::min(bounds.z0, r.cell.z0);
      bounds.x1 = std::max(bounds.x1, r.cell.x1);
      bounds.z1 = std::max(bounds.z1, r.cell.z1);
    }
    std::vector<int> candidates;
    for (size_t i = 0; i < rooms.size(); ++i) {
      const RectCm& c = rooms[i].cell;
      if (rooms[i].type == "hallway") continue;
      const bool cx = c.x0 == bounds.x0 || c.x1 == bounds.x1;
      const bool cz = c.z0 == bounds.z0 || c.z1 == bounds.z1;
      if (cx && cz) candidates.push_back(static_cast<int>(i));
    }
    rng_.shuffle(candidates);
    for (int index : candidates) {
      std::vector<PlanRoom> rest = rooms;
      rest.erase(rest.begin() + index);
      if (connectedByDoors(rest)) {
        rooms = std::move(rest);
        return true;
      }
    }
    return false;
  }

  // ---- doors --------------------------------------------------------------

  bool canHaveDoor(const RectCm& a, const RectCm& b) const {
    const auto c = contact(a, b);
    return c && c->length() >= doorWidth_ + 2 * doorMargin_;
  }

  bool connectedByDoors(const std::vector<PlanRoom>& rooms) const {
    if (rooms.empty()) return false;
    std::vector<bool> seen(rooms.size(), false);
    std::vector<size_t> stack{0};
    seen[0] = true;
    size_t reached = 1;
    while (!stack.empty()) {
      const size_t i = stack.back();
      stack.pop_back();
      for (size_t j = 0; j < rooms.size(); ++j) {
        if (seen[j] || !canHaveDoor(rooms[i].cell, rooms[j].cell)) continue;
        seen[j] = true;
        ++reached;
        stack.push_back(j);
      }
    }
    return reached == rooms.size();
  }

  // ---- room types ---------------------------------------------------------

  void assignTypes(std::vector<PlanRoom>& rooms) {
    const int n = static_cast<int>(rooms.size());
    std::vector<int> order;  // untyped rooms, largest first
    for (int i = 0; i < n; ++i)
      if (rooms[i].type.empty()) order.push_back(i);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return rooms[a].cell.area() > rooms[b].cell.area();
    });
    auto take = [&](int index, const char* type) {
      rooms[index].type = type;
      order.erase(std::find(order.begin(), order.end(), index));
    };
    auto adjacentTo = [&](int a, int b) {
      return canHaveDoor(rooms[a].cell, rooms[b].cell);
    };
    if (order.empty()) return;

    // the living room is one of the two largest rooms
    const int living = order[std::min<int>(rng_.intIn(0, 1), order.size() - 1)];
    take(living, "living room");
    if (order.empty()) return;

    // the kitchen: the largest room next to the living room, if any
    int kitchen = order.front();
    for (int i : order)
      if (adjacentTo(i, living)) {
        kitchen = i;
        break;
      }
    take(kitchen, "kitchen");

    // bathrooms among the smallest rooms (a second one in bigger houses)
    const int bathrooms = n >= 7 && rng_.chance(0.6f) ? 2 : 1;
    for (int b = 0; b < bathrooms && order.size() >= 2; ++b) {
      const int pickFrom = std::min<int>(2, order.size());
      take(order[order.size() - 1 - rng_.intIn(0, pickFrom - 1)], "bathroom");
    }
    if (order.empty()) return;

    // about half of the remaining rooms are bedrooms, the rest special
    // rooms (each with some chance), then bedrooms again
    int extras = static_cast<int>(order.size()) -
                 std::max<int>(1, (static_cast<int>(order.size()) + 1) / 2);
    auto narrowness = [&](int i) {
      const RectCm& c = rooms[i].cell;
      return static_cast<float>(std::max(c.width(), c.depth())) /
             static_cast<float>(std::min(c.width(), c.depth()));
    };
    struct Extra {
      const char* type;
      float chance;
    };
    const Extra pool[] = {{"dining room", 0.8f},
                          {"office", 0.7f},
                          {"laundry room", 0.45f},
                          {"closet", 0.4f},
                          {"bathroom", bathrooms == 1 ? 0.4f : 0.0f},
                          {"hallway", 0.3f},
                          {"office", 0.2f}};
    for (const Extra& extra : pool) {
      if (extras <= 0 || order.empty()) break;
      if (!rng_.chance(extra.chance)) continue;
      const std::string type = extra.type;
      int pick = -1;
      if (type == "dining room") {
        for (int i : order)
          if (adjacentTo(i, kitchen) || adjacentTo(i, living)) {
            pick = i;
            break;
          }
      } else if (type == "office") {
        pick = order[rng_.intIn(0, static_cast<int>(order.size()) - 1)];
      } else if (type == "hallway") {
        // a long narrow room reads as a hallway in plans without a corridor
        int narrowest = order.front();
        for (int i : order)
          if (narrowness(i) > narrowness(narrowest)) narrowest = i;
        if (narrowness(narrowest) >= 1.6f) pick = narrowest;
      } else {
        pick = order.back();  // the smallest room
      }
      if (pick < 0) continue;
      take(pick, extra.type);
      --extras;
    }
    while (!order.empty()) take(order.front(), "bedroom");
  }

  // Spanning tree grown from the hallway (or living room): bathrooms,
  // closets and laundry rooms are leaves where possible; then a few loops.
  void placeDoors(FloorPlan& plan) {
    const auto& rooms = plan.rooms;
    const int n = static_cast<int>(rooms.size());
    int root = 0;
    for (int i = 0; i < n; ++i)
      if (rooms[i].type == "hallway") {
        root = i;
        break;
      }
    if (rooms[root].type != "hallway")
      for (int i = 0; i < n; ++i)
        if (rooms[i].type == "living room") root = i;

    auto affinity = [&](int parent, int child) {
      const std::string& p = rooms[parent].type;
      const std::string& c = rooms[child].type;
      float score = 0.0f;
      if (p == "hallway") score += 0.6f;
      if (c == "bathroom" && (p == "hallway" || p == "bedroom")) score += 1.0f;
      if (c == "closet" && (p == "bedroom" || p == "hallway")) score += 1.0f;
      if (c == "laundry room" && (p == "kitchen" || p == "hallway"))
        score += 1.0f;
      if ((p == "kitchen" && c == "dining room") ||
          (p == "dining room" && c == "kitchen") ||
          (p == "living room" && (c == "dining room" || c == "kitchen")))
        score += 0.5f;
      return score;
    };

    std::vector<bool> inTree(n, false);
    inTree[root] = true;
    std::set<std::pair<int, int>> joined;
    for (int added = 1; added < n; ++added) {
      int bestParent = -1, bestChild = -1;
      float bestScore = -1e9f;
      for (int pass = 0; pass < 2 && bestParent < 0; ++pass) {
        // first pass: never grow the tree out of a leaf-type room
        for (int p = 0; p < n; ++p) {
          if (!inTree[p] || (pass == 0 && isLeafType(rooms[p].type))) continue;
          for (int c = 0; c < n; ++c) {
            if (inTree[c] || !canHaveDoor(rooms[p].cell, rooms[c].cell))
              continue;
            const float score = affinity(p, c) + rng_.uniform();
            if (score > bestScore) {
              bestScore = score;
              bestParent = p;
              bestChild = c;
            }
          }
        }
      }
      VLN_ASSERT(bestParent >= 0);  // connectedByDoors() held for this plan
      inTree[bestChild] = true;
      addDoor(plan, bestParent, bestChild);
      joined.insert(std::minmax(bestParent, bestChild));
    }

    // loops between public rooms make routes less tree-like
    int loops = 0;
    const int maxLoops = std::max(1, n / 3);
    for (int a = 0; a < n; ++a) {
      for (int b = a + 1; b < n; ++b) {
        if (loops >= maxLoops || joined.count({a, b}) ||
            isLeafType(rooms[a].type) || isLeafType(rooms[b].type) ||
            !canHaveDoor(rooms[a].cell, rooms[b].cell))
          continue;
        const bool hall =
            rooms[a].type == "hallway" || rooms[b].type == "hallway";
        if (!rng_.chance(hall ? 0.5f : 0.25f)) continue;
        addDoor(plan, a, b);
        joined.insert({a, b});
        ++loops;
      }
    }
  }

  void addDoor(FloorPlan& plan, int a, int b) {
    const Contact c = *contact(plan.rooms[a].cell, plan.rooms[b].cell);
    const int half = doorWidth_ / 2;
    const int lo = c.lo + doorMargin_ + half;
    const int hi = c.hi - doorMargin_ - (doorWidth_ - half);
    VLN_ASSERT(lo <= hi);
    // 5 cm steps inside the admissible range
    const int steps = (hi - lo) / 5;
    const int center = lo + 5 * rng_.intIn(0, steps);
    PlanDoor door;
    door.room_a = std::min(a, b);
    door.room_b = std::max(a, b);
    door.along_x = c.along_x;
    door.line_cm = c.line;
    door.center_cm = center;
    door.width_cm = doorWidth_;
    plan.doors.push_back(door);
  }

  Rng& rng_;
  const HouseConfig& config_;
  int minSide_;
  int maxSide_;
  int doorWidth_;
  int doorMargin_;
};

}  // namespace

FloorPlan planFloor(Rng& rng, const HouseConfig& config) {
  return Planner(rng, config).run();
}

Doorway toDoorway(const PlanDoor& door) {
  Doorway out;
  out.room_a = door.room_a;
  out.room_b = door.room_b;
  const float line = static_cast<float>(door.line_cm) / 100.0f;
  const float center = static_cast<float>(door.center_cm) / 100.0f;
  out.center =
      door.along_x ? Vec3f(center, 0.0f, line) : Vec3f(line, 0.0f, center);
  out.width = static_cast<float>(door.width_cm) / 100.0f;
  out.normal = door.along_x ? Vec3f::UnitZ() : Vec3f::UnitX();
  return out;
}

}  // namespace vln::world::house
