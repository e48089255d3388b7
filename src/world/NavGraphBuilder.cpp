#include "world/NavGraphBuilder.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <queue>
#include <utility>

#include "common/Check.h"
#include "common/Random.h"

namespace vln::world {

namespace {

// Floor-hole search: rays are cast straight down on a grid of this pitch
// from this height above each room's floor; a floor is "there" when the ray
// meets a surface within kFloorTolerance of floor_y.
constexpr float kHoleGridStep = 0.2f;
constexpr float kHoleRayStart = 1.0f;
constexpr float kFloorTolerance = 0.08f;
// Holes of fewer cells are noise (a ray grazing a seam).
constexpr int kMinHoleCells = 2;
// Objects that start this high above the floor hang on walls (pictures,
// shelves) and do not keep a tripod away.
constexpr float kStandingObjectMaxBase = 0.5f;

// Stream labels for common::deriveSeed(): each decision family draws from its own
// generator so that changing one does not reshuffle the others.
enum Stream : uint64_t {
  kDoorStream = 1,
  kHoleStream = 2,
  kRoomStream = 3,
  kHeightStream = 4,
  kEdgeStream = 5,
  kIdStream = 6,
};

struct Candidate {
  Vec2f xz;
  float floor_y = 0.0f;
  int room = -1;
  NodePlacement placement = NodePlacement::kRoom;
};

struct Hole {
  Vec2f center;
  float floor_y = 0.0f;
  int room = -1;
};

Eigen::AlignedBox2f footprintXZ(const Eigen::AlignedBox3f& box) {
  return {Vec2f(box.min().x(), box.min().z()),
          Vec2f(box.max().x(), box.max().z())};
}

Eigen::AlignedBox2f shrink(const Eigen::AlignedBox2f& box, float margin) {
  Eigen::AlignedBox2f result(box.min() + Vec2f::Constant(margin),
                             box.max() - Vec2f::Constant(margin));
  // a room narrower than twice the margin keeps only its centre line
  for (int k = 0; k < 2; ++k) {
    if (result.min()[k] > result.max()[k]) {
      const float mid = 0.5f * (box.min()[k] + box.max()[k]);
      result.min()[k] = mid;
      result.max()[k] = mid;
    }
  }
  return result;
}

Eigen::AlignedBox2f grow(const Eigen::AlignedBox2f& box, float margin) {
  return {box.min() - Vec2f::Constant(margin),
          box.max() + Vec2f::Constant(margin)};
}

// True for objects standing on the floor at height floorY.
bool standsOn(const sim::SemanticObject& object, float floorY) {
  return object.bounds.min().y() < floorY + kStandingObjectMaxBase &&
         object.bounds.max().y() > floorY + 0.05f;
}

// "Large flat": a table, counter or bed a tripod could be set up over.
bool isLargeFlat(const sim::SemanticObject& object, float floorY,
                 const NavGraphBuildConfig& config) {
  const Vec3f size = object.bounds.sizes();
  const float top = object.bounds.max().y() - floorY;
  return size.x() * size.z() >= config.flat_object_min_area &&
         top <= config.flat_object_max_height && top > 0.3f;
}

// ---------------------------------------------------------------------------
// floor holes
// ---------------------------------------------------------------------------

std::vector<Hole> findHoles(const sim::SceneSemantics& semantics,
                            const sim::RayTracer& tracer) {
  std::vector<Hole> holes;
  for (size_t r = 0; r < semantics.rooms.size(); ++r) {
    const sim::Room& room = semantics.rooms[r];
    const Eigen::AlignedBox2f area = shrink(room.footprint, kHoleGridStep);
    const int nx = 1 + static_cast<int>(area.sizes().x() / kHoleGridStep);
    const int nz = 1 + static_cast<int>(area.sizes().y() / kHoleGridStep);

    // classify every grid cell: hole when the floor is missing below it
    std::vector<char> hole(static_cast<size_t>(nx * nz), 0);
    for (int i = 0; i < nx; ++i) {
      for (int j = 0; j < nz; ++j) {
        const Vec3f origin(area.min().x() + i * kHoleGridStep,
                           room.floor_y + kHoleRayStart,
                           area.min().y() + j * kHoleGridStep);
        const auto hit =
            tracer.cast(origin, Vec3f(0, -1, 0), kHoleRayStart + 0.5f);
        const bool missing =
            !hit || hit->point.y() < room.floor_y - kFloorTolerance;
        hole[static_cast<size_t>(i * nz + j)] = missing ? 1 : 0;
      }
    }

    // flood-fill 4-connected hole cells into holes
    std::vector<char> seen(hole.size(), 0);
    for (int start = 0; start < nx * nz; ++start) {
      if (!hole[static_cast<size_t>(start)] || seen[static_cast<size_t>(start)])
        continue;
      std::vector<int> stack = {start};
      seen[static_cast<size_t>(start)] = 1;
      Vec2f sum = Vec2f::Zero();
      int cells = 0;
      while (!stack.empty()) {
        const int c = stack.back();
        stack.pop_back();
        const int i = c / nz, j = c % nz;
        sum += Vec2f(area.min().x() + i * kHoleGridStep,
                     area.min().y() + j * kHoleGridStep);
        ++cells;
        const std::array<std::pair<int, int>, 4> next = {
            {{i - 1, j}, {i + 1, j}, {i, j - 1}, {i, j + 1}}};
        for (const auto& [a, b] : next) {
          if (a < 0 || b < 0 || a >= nx || b >= nz) continue;
          const int n = a * nz + b;
          if (hole[static_cast<size_t>(n)] && !seen[static_cast<size_t>(n)]) {
            seen[static_cast<size_t>(n)] = 1;
            stack.push_back(n);
          }
        }
      }
      if (cells >= kMinHoleCells)
        holes.push_back({sum / static_cast<float>(cells), room.floor_y,
                         static_cast<int>(r)});
    }
  }
  return holes;
}

// ---------------------------------------------------------------------------
// keeping tripods off furniture
// ---------------------------------------------------------------------------

class FurnitureMap {
 public:
  FurnitureMap(const sim::SceneSemantics& semantics,
               const NavGraphBuildConfig& config)
      : semantics_(semantics), config_(config) {}

  // The object whose footprint (grown by the clearance) contains `c`, or
  // nullptr.
  const sim::SemanticObject* blocking(const Candidate& c) const {
    for (const auto& object : semantics_.objects) {
      if (!standsOn(object, c.floor_y)) continue;
      if (grow(footprintXZ(object.bounds), config_.object_clearance)
              .contains(c.xz))
        return &object;
    }
    return nullptr;
  }

  // Settles `c` relative to furniture: keeps it over a large flat object
  // with probability furniture_node_probability (placement kFurniture),
  // otherwise pushes it just outside the nearest free side. Returns false
  // when no free spot inside `inside` exists.
  bool settle(Candidate& c, const Eigen::AlignedBox2f& inside,
              std::mt19937_64& rng) const {
    const sim::SemanticObject* object = blocking(c);
    if (object == nullptr) return true;
    if (footprintXZ(object->bounds).contains(c.xz) &&
        isLargeFlat(*object, c.floor_y, config_) &&
        common::bernoulli(rng, config_.furniture_node_probability)) {
      c.placement = NodePlacement::kFurniture;
      return true;
    }
    // the four ways out of the grown footprint, nearest first
    const float clearance =
        config_.object_clearance +
        common::uniformRange(rng, 0.0f, config_.object_clearance_spread) + 0.01f;
    const Eigen::AlignedBox2f box =
        grow(footprintXZ(object->bounds), clearance);
    std::array<std::pair<float, Vec2f>, 4> exits = {{
        {c.xz.x() - box.min().x(), Vec2f(box.min().x(), c.xz.y())},
        {box.max().x() - c.xz.x(), Vec2f(box.max().x(), c.xz.y())},
        {c.xz.y() - box.min().y(), Vec2f(c.xz.x(), box.min().y())},
        {box.max().y() - c.xz.y(), Vec2f(c.xz.x(), box.max().y())},
    }};
    std::stable_sort(
        exits.begin(), exits.end(),
        [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [distance, xz] : exits) {
      Candidate moved = c;
      moved.xz = xz;
      if (inside.contains(xz) && blocking(moved) == nullptr) {
        c = moved;
        return true;
      }
    }
    return false;
  }

 private:
  const sim::SceneSemantics& semantics_;
  const NavGraphBuildConfig& config_;
};

// ---------------------------------------------------------------------------
// edges
// ---------------------------------------------------------------------------

// True when a and b stay connected in `adjacency` without the edge a-b
// (entries marked removed are skipped).
bool connectedWithout(const std::vector<std::vector<std::pair<int, bool>>>& adj,
                      int a, int b) {
  std::vector<char> seen(adj.size(), 0);
  std::vector<int> stack = {a};
  seen[static_cast<size_t>(a)] = 1;
  while (!stack.empty()) {
    const int u = stack.back();
    stack.pop_back();
    for (const auto& [v, removed] : adj[static_cast<size_t>(u)]) {
      if (removed || (u == a && v == b) || (u == b && v == a)) continue;
      if (v == b) return true;
      if (!seen[static_cast<size_t>(v)]) {
        seen[static_cast<size_t>(v)] = 1;
        stack.push_back(v);
      }
    }
  }
  return false;
}

void markRemoved(std::vector<std::vector<std::pair<int, bool>>>& adj, int a,
                 int b) {
  for (auto& [v, removed] : adj[static_cast<size_t>(a)])
    if (v == b) removed = true;
  for (auto& [v, removed] : adj[static_cast<size_t>(b)])
    if (v == a) removed = true;
}

std::string viewpointId(uint64_t seed, int index) {
  const uint64_t hi = common::deriveSeed(seed, 2 * static_cast<uint64_t>(index));
  const uint64_t lo = common::deriveSeed(seed, 2 * static_cast<uint64_t>(index) + 1);
  char buffer[33];
  std::snprintf(buffer, sizeof(buffer), "%016llx%016llx",
                static_cast<unsigned long long>(hi),
                static_cast<unsigned long long>(lo));
  return buffer;
}

}  // namespace

std::string nodePlacementName(NodePlacement placement) {
  switch (placement) {
    case NodePlacement::kRoom:
      return "room";
    case NodePlacement::kDoorway:
      return "doorway";
    case NodePlacement::kFurniture:
      return "furniture";
    case NodePlacement::kHole:
      return "hole";
  }
  VLN_ASSERT(false);
  return {};
}

BuiltNavGraph buildNavGraph(const sim::SceneSemantics& semantics,
                            const sim::RayTracer& tracer,
                            const NavGraphBuildConfig& config, uint64_t seed) {
  config.validate();
  VLN_CHECK_ARG(!semantics.rooms.empty(),
                "buildNavGraph(): the house has no room semantics to place "
                "panoramas in");
  const FurnitureMap furniture(semantics, config);
  std::vector<Candidate> accepted;
  const auto farFromAccepted = [&](const Candidate& c) {
    for (const Candidate& a : accepted)
      if (std::abs(a.floor_y - c.floor_y) < 1.0f &&
          (a.xz - c.xz).norm() < config.min_node_separation)
        return false;
    return true;
  };

  // doorways first: operators always captured the way between rooms
  std::mt19937_64 doorRng(common::deriveSeed(seed, kDoorStream));
  for (const sim::Doorway& door : semantics.doors) {
    const bool interior = door.room_a >= 0 && door.room_b >= 0;
    const bool take = common::bernoulli(doorRng, config.doorway_node_probability);
    if (!interior || !take) continue;
    Candidate c{Vec2f(door.center.x(), door.center.z()), door.center.y(),
                door.room_a, NodePlacement::kDoorway};
    if (farFromAccepted(c)) accepted.push_back(c);
  }

  // then holes in the floor, where the scan under a tripod failed
  const std::vector<Hole> holes = findHoles(semantics, tracer);
  std::mt19937_64 holeRng(common::deriveSeed(seed, kHoleStream));
  for (const Hole& hole : holes) {
    if (!common::bernoulli(holeRng, config.hole_node_probability)) continue;
    Candidate c{hole.center, hole.floor_y, hole.room, NodePlacement::kHole};
    if (farFromAccepted(c) && furniture.blocking(c) == nullptr)
      accepted.push_back(c);
  }

  // then a jittered grid over every room, kept off furniture
  for (size_t r = 0; r < semantics.rooms.size(); ++r) {
    const sim::Room& room = semantics.rooms[r];
    std::mt19937_64 rng(common::deriveSeed(seed, kRoomStream * 1000003ull + r));
    const Eigen::AlignedBox2f inner =
        shrink(room.footprint, config.wall_margin);
    const Eigen::AlignedBox2f roomy =
        shrink(room.footprint, 0.5f * config.wall_margin);
    std::array<int, 2> count{};
    for (int k = 0; k < 2; ++k)
      count[static_cast<size_t>(k)] =
          1 + static_cast<int>(
                  std::floor(inner.sizes()[k] / config.node_spacing + 0.35f));
    for (int i = 0; i < count[0]; ++i) {
      for (int j = 0; j < count[1]; ++j) {
        Vec2f xz;
        const std::array<int, 2> ij = {i, j};
        for (int k = 0; k < 2; ++k) {
          const int n = count[static_cast<size_t>(k)];
          const float t = n == 1
                              ? 0.5f
                              : static_cast<float>(ij[static_cast<size_t>(k)]) /
                                    static_cast<float>(n - 1);
          xz[k] =
              inner.min()[k] + t * inner.sizes()[k] +
              common::uniformRange(rng, -config.spacing_jitter, config.spacing_jitter);
          xz[k] = std::clamp(xz[k], inner.min()[k], inner.max()[k]);
        }
        Candidate c{xz, room.floor_y, static_cast<int>(r),
                    NodePlacement::kRoom};
        if (!furniture.settle(c, roomy, rng)) continue;
        if (farFromAccepted(c)) accepted.push_back(c);
      }
    }
  }

  // nodes at tripod height with R2R-like ids
  BuiltNavGraph built;
  std::mt19937_64 heightRng(common::deriveSeed(seed, kHeightStream));
  const uint64_t idSeed = common::deriveSeed(seed, kIdStream);
  for (size_t i = 0; i < accepted.size(); ++i) {
    const Candidate& c = accepted[i];
    const float height = common::uniformRange(heightRng, config.min_camera_height,
                                      config.max_camera_height);
    built.graph.addNode(viewpointId(idSeed, static_cast<int>(i)),
                        Vec3f(c.xz.x(), c.floor_y + height, c.xz.y()));
    built.placement.push_back(c.placement);
    built.room.push_back(c.room);
  }
  built.holes_found = static_cast<int>(holes.size());

  // edges: line of sight at camera height within reach
  const int n = built.graph.numNodes();
  std::vector<std::pair<int, int>> visible;
  std::vector<std::vector<std::pair<int, bool>>> adjacency(
      static_cast<size_t>(n));
  for (int a = 0; a < n; ++a) {
    for (int b = a + 1; b < n; ++b) {
      const Vec3f& pa = built.graph.node(a).position;
      const Vec3f& pb = built.graph.node(b).position;
      if (horizontalDistance(pa, pb) > config.max_edge_length) continue;
      if (!tracer.visible(pa, pb)) continue;
      visible.emplace_back(a, b);
      adjacency[static_cast<size_t>(a)].emplace_back(b, false);
      adjacency[static_cast<size_t>(b)].emplace_back(a, false);
    }
  }

  // annotators pruned some redundant edges, never one that disconnects
  std::mt19937_64 edgeRng(common::deriveSeed(seed, kEdgeStream));
  for (const auto& [a, b] : visible) {
    if (common::bernoulli(edgeRng, config.edge_drop_probability) &&
        connectedWithout(adjacency, a, b)) {
      markRemoved(adjacency, a, b);
      continue;
    }
    built.graph.addEdge(built.graph.node(a).id, built.graph.node(b).id);
  }
  return built;
}

std::vector<int> componentSizes(const data::NavGraph& graph) {
  std::vector<int> sizes;
  std::vector<char> seen(static_cast<size_t>(graph.numNodes()), 0);
  for (int start = 0; start < graph.numNodes(); ++start) {
    if (seen[static_cast<size_t>(start)]) continue;
    int size = 0;
    std::vector<int> stack = {start};
    seen[static_cast<size_t>(start)] = 1;
    while (!stack.empty()) {
      const int u = stack.back();
      stack.pop_back();
      ++size;
      for (const int v : graph.neighbors(u)) {
        if (!seen[static_cast<size_t>(v)]) {
          seen[static_cast<size_t>(v)] = 1;
          stack.push_back(v);
        }
      }
    }
    sizes.push_back(size);
  }
  std::sort(sizes.begin(), sizes.end(), std::greater<>());
  return sizes;
}

}  // namespace vln::world
