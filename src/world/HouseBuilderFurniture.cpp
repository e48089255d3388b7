// Furniture placement in procedural houses: models of the catalogue
// (HouseBuilderModels.cpp) placed per room type
// (against walls, in the middle, hung on walls) with three guarantees:
//  - no object overlaps another object or a doorway's clear zone;
//  - every object lies inside its room;
//  - the room stays navigable: an agent needing corridors of 0.6 m
//    reaches every doorway and gets next to every object
//    (HouseBuilderClearance.cpp).

// First of all includes: no FMA contraction (see the header).
#include "world/HouseFpContract.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>

#include "common/Check.h"
#include "world/HouseBuilder.h"

namespace vln::world::house {
namespace {

using Box2 = Eigen::AlignedBox2f;
using Box3 = Eigen::AlignedBox3f;

constexpr float kWallGap = 0.01f;  // furniture stands this far off walls
constexpr float kObjectGap = 0.01f;

// ===========================================================================
// placement
// ===========================================================================

// A model placed relative to its group: offset of its local origin and an
// extra quarter-turn.
struct Member {
  Model model;
  float ox = 0.0f, oz = 0.0f;
  int turn = 0;
};
using Group = std::vector<Member>;
// accepts a wall placement: (side, near end, far end along the wall)
using SpanFilter = std::function<bool(int, float, float)>;

// local (x, z) rotated by `turn` quarter turns about +y
Vec2f rotate(float x, float z, int turn) {
  switch (turn & 3) {
    case 0:
      return {x, z};
    case 1:
      return {z, -x};
    case 2:
      return {-x, -z};
    default:
      return {-z, x};
  }
}

Shape rotateShape(Shape shape, int turn) {
  if ((turn & 1) == 0) return shape;
  if (shape == Shape::kCylinderX) return Shape::kCylinderZ;
  if (shape == Shape::kCylinderZ) return Shape::kCylinderX;
  return shape;
}

// A member's parts in the world for group anchor (ax, az) and turn.
std::vector<Part> worldParts(const Member& member, float ax, float az,
                             int turn) {
  const Vec2f origin = Vec2f(ax, az) + rotate(member.ox, member.oz, turn);
  const int total = turn + member.turn;
  std::vector<Part> out;
  for (const Part& p : member.model.parts) {
    const Vec2f a = rotate(p.box.min().x(), p.box.min().z(), total);
    const Vec2f b = rotate(p.box.max().x(), p.box.max().z(), total);
    Part q = p;
    q.shape = rotateShape(p.shape, total);
    q.box = Box3(Vec3f(origin.x() + std::min(a.x(), b.x()), p.box.min().y(),
                       origin.y() + std::min(a.y(), b.y())),
                 Vec3f(origin.x() + std::max(a.x(), b.x()), p.box.max().y(),
                       origin.y() + std::max(a.y(), b.y())));
    out.push_back(q);
  }
  return out;
}

Box3 boundsOf(const std::vector<Part>& parts) {
  Box3 box;
  for (const Part& p : parts) box.extend(p.box);
  return box;
}

// strict overlap with a tolerance: touching boxes do not overlap
bool overlaps(const Box2& a, const Box2& b, float gap) {
  return a.min().x() < b.max().x() + gap && b.min().x() < a.max().x() + gap &&
         a.min().y() < b.max().y() + gap && b.min().y() < a.max().y() + gap;
}
bool overlaps(const Box3& a, const Box3& b, float gap) {
  for (int i = 0; i < 3; ++i)
    if (!(a.min()[i] < b.max()[i] + gap && b.min()[i] < a.max()[i] + gap))
      return false;
  return true;
}

float cmToM(int value) { return static_cast<float>(value) / 100.0f; }

// The state of one room while it is being furnished.
class RoomFurnisher {
 public:
  RoomFurnisher(Rng& rng, const FloorPlan& plan, int room,
                const HouseConfig& config, const std::string& windowColor,
                std::vector<PlacedObject>& objects)
      : rng_(rng),
        plan_(plan),
        room_(room),
        config_(config),
        windowColor_(windowColor),
        objects_(objects),
        models_(rng, config.wall_height - 0.1f) {
    const RectCm& cell = plan.rooms[room].cell;
    const float h = 0.5f * config.wall_thickness;
    interior_ = Box2(Vec2f(cmToM(cell.x0) + h, cmToM(cell.z0) + h),
                     Vec2f(cmToM(cell.x1) - h, cmToM(cell.z1) - h));
    for (const PlanDoor& door : plan.doors) {
      if (door.room_a != room && door.room_b != room) continue;
      const Doorway d = toDoorway(door);
      zones_.push_back(doorwayClearZone(d));
      // a point half a metre into this room in front of the opening
      const Vec2f center(d.center.x(), d.center.z());
      const Vec2f normal(d.normal.x(), d.normal.z());
      const Vec2f mid = interior_.center();
      const float side = (mid - center).dot(normal) >= 0.0f ? 1.0f : -1.0f;
      seeds_.push_back(center + side * (0.5f * kDoorwayClearDepth) * normal);
    }
    if (seeds_.empty()) seeds_.push_back(interior_.center());
    for (const PlacedObject& o : objects)
      if (o.semantic.room == room) placed_.push_back(o.semantic.bounds);
  }

  // ---- recipes ------------------------------------------------------------
  void furnish(const std::string& type) {
    const float density = config_.furniture_density;
    if (density <= 0.0f) return;
    auto maybe = [&](float p) {
      return rng_.chance(std::min(1.0f, p * density));
    };

    if (type == "bedroom") {
      bedGroup();
      windows(maybe(0.5f) ? 2 : 1);
      if (maybe(0.7f)) wall(models_.wardrobe());
      if (maybe(0.5f)) wall(models_.dresser());
      if (maybe(0.15f)) deskGroup();
      if (maybe(0.2f)) wall(models_.sofa(/*armchair=*/true));
      if (maybe(0.3f)) wall(models_.plant());
      if (maybe(0.35f)) wall(models_.lamp());
      for (int i = 0; i < 2; ++i)
        if (maybe(i == 0 ? 0.6f : 0.25f)) hang(models_.picture());
      if (maybe(0.2f)) hang(models_.mirror());
      if (maybe(0.35f)) center(single(models_.rug(false)), /*rug=*/true);
    } else if (type == "living room") {
      livingGroup();
      windows(maybe(0.6f) ? 2 : 1);
      for (int i = 0; i < 2; ++i)
        if (maybe(i == 0 ? 0.6f : 0.3f)) wall(models_.sofa(/*armchair=*/true));
      if (maybe(0.45f)) wall(models_.bookcase());
      if (maybe(0.3f)) wall(models_.shelf());
      for (int i = 0; i < 2; ++i)
        if (maybe(i == 0 ? 0.7f : 0.4f)) wall(models_.plant());
      if (maybe(0.55f)) wall(models_.lamp());
      if (maybe(0.12f)) wall(models_.piano());
      if (maybe(0.25f)) wall(models_.cabinet());
      for (int i = 0; i < 2; ++i)
        if (maybe(i == 0 ? 0.8f : 0.5f)) hang(models_.picture());
      if (maybe(0.45f)) center(single(models_.rug(false)), /*rug=*/true);
    } else if (type == "kitchen") {
      kitchenRun();
      windows(1);
      if (maybe(0.45f)) center(single(islandModel()), false);
      if (maybe(0.3f)) diningGroup(/*small=*/true);
      if (maybe(0.3f)) wall(models_.cabinet());
      if (maybe(0.2f)) wall(models_.plant());
      if (maybe(0.3f)) hang(models_.picture());
    } else if (type == "dining room") {
      diningGroup(/*small=*/false);
      windows(maybe(0.5f) ? 2 : 1);
      if (maybe(0.5f)) wall(models_.cabinet());
      if (maybe(0.3f)) wall(models_.shelf());
      for (int i = 0; i < 2; ++i)
        if (maybe(i == 0 ? 0.6f : 0.3f)) wall(models_.plant());
      if (maybe(0.3f)) wall(models_.lamp());
      for (int i = 0; i < 2; ++i)
        if (maybe(i == 0 ? 0.7f : 0.3f)) hang(models_.picture());
    } else if (type == "bathroom") {
      wall(models_.toilet());
      const int sinkAt = static_cast<int>(placedModels_.size());
      wall(models_.sink(/*kitchen=*/false, "white", "white"));
      if (static_cast<int>(placedModels_.size()) > sinkAt && maybe(0.75f))
        hangAbove(models_.mirror(), placedModels_.back());
      if (maybe(0.7f)) wall(models_.bathtub());
      if (maybe(0.5f)) windows(1);
      if (maybe(0.35f)) wall(models_.cabinet());
      if (maybe(0.15f)) wall(models_.washer());
      if (maybe(0.2f)) wall(models_.plant());
      if (maybe(0.4f))
        center(single(models_.rug(/*small=*/true)), /*rug=*/true);
    } else if (type == "hallway") {
      if (maybe(0.4f)) windows(1);
      if (maybe(0.5f)) wall(models_.plant());
      if (maybe(0.4f))
        wall(rng_.chance(0.5f) ? models_.cabinet() : models_.shelf());
      if (maybe(0.2f)) wall(models_.lamp());
      for (int i = 0; i < 3; ++i)
        if (maybe(i == 0 ? 0.7f : 0.4f)) hang(models_.picture());
      if (maybe(0.3f)) hang(models_.mirror());
      if (maybe(0.3f)) center(single(models_.rug(false)), /*rug=*/true);
    } else if (type == "office") {
      deskGroup();
      windows(1);
      if (maybe(0.75f)) wall(models_.bookcase());
      if (maybe(0.35f)) wall(models_.shelf());
      if (maybe(0.45f)) wall(models_.lamp());
      if (maybe(0.5f)) wall(models_.plant());
      if (maybe(0.35f)) wall(models_.cabinet());
      if (maybe(0.3f)) wall(models_.sofa(/*armchair=*/true));
      if (maybe(0.5f)) hang(models_.picture());
      if (maybe(0.3f)) center(single(models_.rug(false)), /*rug=*/true);
    } else if (type == "laundry room") {
      wall(models_.washer());
      if (maybe(0.4f)) wall(models_.washer());
      if (maybe(0.4f)) windows(1);
      if (maybe(0.5f)) wall(models_.cabinet());
      if (maybe(0.5f)) wall(models_.shelf());
      if (maybe(0.3f)) wall(models_.sink(/*kitchen=*/true, "white", "grey"));
    } else if (type == "closet") {
      wall(models_.shelf());
      if (maybe(0.5f)) wall(models_.shelf());
      if (maybe(0.4f)) wall(models_.cabinet());
      if (maybe(0.35f)) wall(models_.dresser());
      if (maybe(0.3f)) hang(models_.mirror());
    }
  }

  // Cuts a hole of size (sx, sz) somewhere free in this room; false if none.
  bool cutHole(float sx, float sz, Box2& hole) {
    const float margin = 0.3f;
    const float x0 = interior_.min().x() + margin,
                x1 = interior_.max().x() - margin - sx;
    const float z0 = interior_.min().y() + margin,
                z1 = interior_.max().y() - margin - sz;
    if (x1 <= x0 || z1 <= z0) return false;
    for (int attempt = 0; attempt < 40; ++attempt) {
      // on a 5 cm grid, like the rest of the plan
      const float x = std::round(rng_.uniform(x0, x1) * 20.0f) / 20.0f;
      const float z = std::round(rng_.uniform(z0, z1) * 20.0f) / 20.0f;
      const Box2 candidate(Vec2f(x, z), Vec2f(x + sx, z + sz));
      if (!interior_.contains(candidate)) continue;
      bool clear = true;
      for (const Box2& zone : zones_)
        clear = clear && !overlaps(candidate, zone, 0.2f);
      for (const Box3& box : placed_)
        clear = clear && !overlaps(candidate, footprint(box), 0.1f);
      if (!clear) continue;
      if (!navigable({candidate})) continue;
      hole = candidate;
      return true;
    }
    return false;
  }

 private:
  // ---- groups -------------------------------------------------------------
  static Group single(Model m) { return {Member{std::move(m), 0.0f, 0.0f, 0}}; }

  void bedGroup() {
    const Model bed = models_.bed();
    const Model stand = models_.nightstand();
    const float off = bed.width / 2 + 0.05f + stand.width / 2;
    std::vector<Group> variants;
    variants.push_back({{bed}, {stand, -off, 0.0f, 0}, {stand, off, 0.0f, 0}});
    variants.push_back({{bed}, {stand, -off, 0.0f, 0}});
    variants.push_back({{bed}, {stand, off, 0.0f, 0}});
    variants.push_back({{bed}});
    for (const Group& g : variants)
      if (wallGroup(g)) return;
  }

  void livingGroup() {
    const Model sofa = models_.sofa(/*armchair=*/false);
    const Model coffee =
        models_.table("coffee table", 0.9f, 1.2f, 0.5f, 0.62f, 0.42f,
                      {"wooden", "white", "black", "brown", "grey"});
    std::vector<Group> variants;
    if (rng_.chance(std::min(1.0f, 0.8f * config_.furniture_density)))
      variants.push_back({{sofa}, {coffee, 0.0f, sofa.depth + 0.4f, 0}});
    variants.push_back({{sofa}});
    for (const Group& g : variants) {
      if (!wallGroup(g)) continue;
      // the tv faces the sofa from the opposite wall when it can
      if (rng_.chance(std::min(1.0f, 0.8f * config_.furniture_density))) {
        const int opposite = lastSide_ ^ 1;
        const float along = lastAlong_;
        if (!wallGroup(single(models_.tv()), opposite, along))
          wall(models_.tv());
      }
      return;
    }
  }

  void deskGroup() {
    const Model desk = models_.desk();
    const Model chair = models_.chair(
        models_.chooseColor({"black", "grey", "white", "blue", "red"}));
    // the chair faces the desk (half a turn), pulled out in front of it
    const float oz = desk.depth + 0.08f + chair.depth;
    if (!wallGroup({{desk}, {chair, 0.2f, oz, 2}})) wallGroup({{desk}});
  }

  void diningGroup(bool small) {
    const Model table =
        small ? models_.table("table", 0.9f, 1.2f, 0.7f, 0.8f, 0.75f,
                              {"wooden", "white", "black", "brown"})
              : models_.table("table", 1.3f, 2.0f, 0.8f, 1.0f, 0.75f,
                              {"wooden", "white", "black", "brown"});
    const std::string chairColor = models_.chooseColor(
        {"wooden", "white", "black", "red", "blue", "green", "yellow", "grey"});
    const Model chair = models_.chair(chairColor);
    const float w = table.width, d = table.depth, dc = chair.depth, gap = 0.05f;
    const int perSide = std::clamp(static_cast<int>((w - 0.1f) / 0.6f), 1, 3);
    auto build = [&](int side, bool ends) {
      // the table is centred on the group origin
      Group g{{table, 0.0f, -d / 2, 0}};
      for (int i = 0; i < side; ++i) {
        const float x = -w / 2 + w * (static_cast<float>(i) + 0.5f) /
                                     static_cast<float>(side);
        g.push_back({chair, x, d / 2 + gap + dc, 2});
        g.push_back({chair, -x, -d / 2 - gap - dc, 0});
      }
      if (ends) {
        g.push_back({chair, w / 2 + gap + dc, 0.0f, 3});
        g.push_back({chair, -w / 2 - gap - dc, 0.0f, 1});
      }
      return g;
    };
    std::vector<Group> variants;
    if (!small && w >= 1.5f) variants.push_back(build(perSide, true));
    variants.push_back(build(perSide, false));
    if (perSide > 1) variants.push_back(build(perSide - 1, false));
    variants.push_back(build(1, false));
    variants.push_back({{table, 0.0f, -d / 2, 0}});
    for (const Group& g : variants)
      if (center(g, false)) return;
  }

  Model islandModel() { return models_.island(kitchenColor_, kitchenTop_); }

  // Fridge, counters, stove and sink packed along walls from a corner.
  void kitchenRun() {
    kitchenColor_ = models_.chooseColor(
        {"white", "wooden", "grey", "blue", "green", "black", "red", "yellow"});
    kitchenTop_ = models_.chooseColor({"black", "grey", "white", "wooden"});
    if (kitchenTop_ == kitchenColor_)
      kitchenTop_ = kitchenColor_ == "black" ? "grey" : "black";
    std::vector<Model> run;
    run.push_back(models_.fridge());
    run.push_back(
        models_.counter(kitchenColor_, kitchenTop_, rng_.uniform(0.6f, 1.2f)));
    run.push_back(models_.stove());
    run.push_back(
        models_.counter(kitchenColor_, kitchenTop_, rng_.uniform(0.4f, 0.9f)));
    run.push_back(models_.sink(/*kitchen=*/true, kitchenColor_, kitchenTop_));
    if (rng_.chance(0.6f))
      run.push_back(models_.counter(kitchenColor_, kitchenTop_,
                                    rng_.uniform(0.6f, 1.4f)));
    if (rng_.chance(0.5f)) std::reverse(run.begin(), run.end());
    std::vector<int> sides{0, 1, 2, 3};
    rng_.shuffle(sides);
    size_t side = 0;
    float cursor = -1e9f;
    for (const Model& m : run) {
      bool done = false;
      while (!done && side < sides.size()) {
        done = wallGroup(single(m), sides[side], std::nullopt, cursor);
        if (done) {
          cursor = lastAlongMax_;
        } else {
          ++side;
          cursor = -1e9f;
        }
      }
      if (!done) {
        // out of wall: anywhere that fits
        if (m.category != "counter") wall(m);
        side = 0;
        cursor = -1e9f;
      }
    }
  }

  // ---- placement primitives ----------------------------------------------

  bool wall(const Model& m) { return wallGroup(single(m)); }

  // Windows go on outside walls only.
  void windows(int count) {
    for (int i = 0; i < count; ++i)
      wallGroup(
          single(models_.window(config_.wall_height, windowColor_)),
          std::nullopt, std::nullopt, std::nullopt,
          [this](int side, float a, float b) { return exterior(side, a, b); });
  }

  // Whether the wall on `side` of this room faces the outside over the
  // along-wall span [a, b] (metres).
  bool exterior(int side, float a, float b) const {
    const RectCm& cell = plan_.rooms[room_].cell;
    // a point 1 cm beyond the cell edge, in centimetres
    const int across = side == 0   ? cell.z0 - 1
                       : side == 1 ? cell.z1 + 1
                       : side == 2 ? cell.x0 - 1
                                   : cell.x1 + 1;
    for (float t = a; t <= b + 1e-4f; t += 0.05f) {
      const int along = static_cast<int>(std::floor(std::min(t, b) * 100.0f));
      const int x = side < 2 ? along : across;
      const int z = side < 2 ? across : along;
      for (const PlanRoom& other : plan_.rooms)
        if (x > other.cell.x0 && x < other.cell.x1 && z > other.cell.z0 &&
            z < other.cell.z1)
          return false;
    }
    return true;
  }

  // Against a wall. `side`: 0 min z, 1 max z, 2 min x, 3 max x (or any);
  // `prefer`: try along-wall positions nearest to it first; `from`: scan
  // positions upwards from this one (packing runs).
  bool wallGroup(const Group& g, std::optional<int> side = std::nullopt,
                 std::optional<float> prefer = std::nullopt,
                 std::optional<float> from = std::nullopt,
                 const SpanFilter& accept = {}) {
    std::vector<int> sides{0, 1, 2, 3};
    if (side)
      sides = {*side};
    else
      rng_.shuffle(sides);
    // the group's extent across the wall (x of the group frame)
    float gx0 = 1e9f, gx1 = -1e9f;
    for (const Member& m : g) {
      for (const Part& p : worldParts(m, 0.0f, 0.0f, 0)) {
        gx0 = std::min(gx0, p.box.min().x());
        gx1 = std::max(gx1, p.box.max().x());
      }
    }
    for (int s : sides) {
      // side -> quarter turns so that the group's front (+z) faces the room
      static const int kTurn[4] = {0, 2, 1, 3};
      const int turn = kTurn[s];
      const bool alongX = s < 2;
      const float lo = alongX ? interior_.min().x() : interior_.min().y();
      const float hi = alongX ? interior_.max().x() : interior_.max().y();
      // along-wall coordinate of the group origin so its extent fits
      const bool flipped = s == 1 || s == 2;  // local +x runs against the axis
      const float tMin = lo + (flipped ? gx1 : -gx0) + kWallGap;
      const float tMax = hi - (flipped ? -gx0 : gx1) - kWallGap;
      if (tMax < tMin) continue;
      // along-wall position t puts the group's near end (towards lower
      // coordinates) at t + nearOffset and its far end at t + farOffset
      const float nearOffset = flipped ? -gx1 : gx0;
      const float farOffset = flipped ? -gx0 : gx1;
      // packing a run: start just past the previous item's far end
      const float first =
          from ? std::max(tMin, *from - nearOffset + 2 * kObjectGap) : tMin;
      std::vector<float> ts;
      for (float t = first; t <= tMax + 1e-4f; t += 0.05f)
        ts.push_back(std::min(t, tMax));
      if (ts.empty()) continue;
      if (ts.back() < tMax - 1e-4f) ts.push_back(tMax);
      if (from) {
        // keep the ascending order
      } else if (prefer) {
        std::stable_sort(ts.begin(), ts.end(), [&](float a, float b) {
          return std::abs(a - *prefer) < std::abs(b - *prefer);
        });
      } else {
        rng_.shuffle(ts);
        // corners are where much furniture stands
        if (rng_.chance(0.4f)) {
          ts.insert(ts.begin(), tMax);
          ts.insert(ts.begin(), tMin);
        }
      }
      const float wallAt = s == 0   ? interior_.min().y() + kWallGap
                           : s == 1 ? interior_.max().y() - kWallGap
                           : s == 2 ? interior_.min().x() + kWallGap
                                    : interior_.max().x() - kWallGap;
      for (float t : ts) {
        if (accept && !accept(s, t + nearOffset, t + farOffset)) continue;
        const float ax = alongX ? t : wallAt;
        const float az = alongX ? wallAt : t;
        if (tryPlace(g, ax, az, turn, false)) {
          lastSide_ = s;
          lastAlong_ = t;
          lastAlongMax_ = t + farOffset;
          return true;
        }
      }
    }
    return false;
  }

  // Anywhere on the floor, on a 10 cm grid, in one of four orientations.
  bool center(const Group& g, bool rug) {
    std::vector<Vec2f> anchors;
    for (float x = interior_.min().x(); x <= interior_.max().x();
         x += kGridCell)
      for (float z = interior_.min().y(); z <= interior_.max().y();
           z += kGridCell)
        anchors.emplace_back(x, z);
    rng_.shuffle(anchors);
    const int tries = std::min<int>(static_cast<int>(anchors.size()), 300);
    for (int i = 0; i < tries; ++i) {
      const int turn = rng_.intIn(0, 3);
      if (tryPlace(g, anchors[i].x(), anchors[i].y(), turn, rug)) return true;
    }
    return false;
  }

  // On a wall, at its model height.
  bool hang(const Model& m) { return wallGroup(single(m)); }

  // On the wall above another object, centred on it when possible.
  void hangAbove(const Model& m, const Box3& below) {
    const Vec2f c = footprint(below).center();
    const int s = lastSide_;
    const float along = s < 2 ? c.x() : c.y();
    if (!wallGroup(single(m), s, along)) hang(m);
  }

  bool tryPlace(const Group& g, float ax, float az, int turn, bool rug) {
    std::vector<std::vector<Part>> parts;
    std::vector<Box3> boxes;
    for (const Member& m : g) {
      parts.push_back(worldParts(m, ax, az, turn));
      const Box3 box = boundsOf(parts.back());
      // inside the room, clear of doorways and of everything placed
      if (!interior_.contains(footprint(box))) return false;
      for (const Box2& zone : zones_)
        if (overlaps(footprint(box), zone, 0.0f)) return false;
      for (const Box3& other : placed_)
        if (overlaps(box, other, kObjectGap)) return false;
      for (const Box3& other : boxes)
        if (overlaps(box, other, kObjectGap)) return false;
      // a rug lies on bare floor only
      if (rug)
        for (const Box3& other : placed_)
          if (overlaps(footprint(box), footprint(other), kObjectGap))
            return false;
      boxes.push_back(box);
    }
    const size_t before = placed_.size();
    placed_.insert(placed_.end(), boxes.begin(), boxes.end());
    if (!navigable({})) {
      placed_.resize(before);
      return false;
    }
    for (size_t i = 0; i < g.size(); ++i) {
      PlacedObject object;
      object.semantic.id = static_cast<int>(objects_.size());
      object.semantic.category = g[i].model.category;
      object.semantic.color = g[i].model.color;
      object.semantic.room = room_;
      object.semantic.bounds = boxes[i];
      object.parts = std::move(parts[i]);
      objects_.push_back(std::move(object));
      placedModels_.push_back(boxes[i]);
    }
    return true;
  }

  // With `extra` obstacles added, do all doorways of the room connect, and
  // does the agent get next to every object? (HouseBuilderClearance.cpp)
  bool navigable(const std::vector<Box2>& extra) const {
    return roomStaysNavigable(interior_, seeds_, placed_, extra);
  }

  Rng& rng_;
  const FloorPlan& plan_;
  int room_;
  const HouseConfig& config_;
  const std::string& windowColor_;  // one window style per house
  std::vector<PlacedObject>& objects_;
  ModelBuilder models_;
  Box2 interior_;
  std::vector<Box2> zones_;
  std::vector<Vec2f> seeds_;
  std::vector<Box3> placed_;        // bounds of this room's objects
  std::vector<Box3> placedModels_;  // same, in placement order (for hangAbove)
  int lastSide_ = 0;
  float lastAlong_ = 0.0f;
  float lastAlongMax_ = 0.0f;
  std::string kitchenColor_ = "white";
  std::string kitchenTop_ = "black";
};

}  // namespace

// ===========================================================================
// entry points
// ===========================================================================

std::vector<PlacedObject> furnish(Rng& rng, const FloorPlan& plan,
                                  const HouseConfig& config,
                                  std::vector<Eigen::AlignedBox2f>& holes) {
  std::vector<PlacedObject> objects;
  // one window style for the whole house, as builders do
  Rng windowRng = rng.fork(0x57494E);
  const std::vector<std::string> frames = {"white", "white", "black", "wooden",
                                           "grey"};
  const std::string windowColor =
      frames[windowRng.intIn(0, static_cast<int>(frames.size()) - 1)];
  for (size_t r = 0; r < plan.rooms.size(); ++r) {
    // each room draws from its own stream: changing one room's recipe
    // leaves the others unchanged
    Rng roomRng = rng.fork(r);
    RoomFurnisher(roomRng, plan, static_cast<int>(r), config, windowColor,
                  objects)
        .furnish(plan.rooms[r].type);
  }

  Rng holeRng = rng.fork(0x401E);
  if (holeRng.chance(config.floor_hole_probability)) {
    std::vector<int> rooms;
    for (size_t r = 0; r < plan.rooms.size(); ++r)
      if (plan.rooms[r].type != "closet") rooms.push_back(static_cast<int>(r));
    holeRng.shuffle(rooms);
    const float sx = std::round(holeRng.uniform(0.5f, 1.0f) * 20.0f) / 20.0f;
    const float sz = std::round(holeRng.uniform(0.5f, 1.0f) * 20.0f) / 20.0f;
    for (int r : rooms) {
      Box2 hole;
      if (RoomFurnisher(holeRng, plan, r, config, windowColor, objects)
              .cutHole(sx, sz, hole)) {
        holes.push_back(hole);
        break;
      }
    }
  }
  return objects;
}

}  // namespace vln::world::house
