#include "world/NavGraphBuilder.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>

#include "sim/RayTracer.h"
#include "world/HouseGenerator.h"

namespace vln::world {
namespace {

bool isHex32(const std::string& id) {
  return id.size() == 32 && std::all_of(id.begin(), id.end(), [](char c) {
           return std::isxdigit(static_cast<unsigned char>(c)) &&
                  !std::isupper(static_cast<unsigned char>(c));
         });
}

Eigen::AlignedBox2f footprint(const Eigen::AlignedBox3f& box) {
  return {Vec2f(box.min().x(), box.min().z()),
          Vec2f(box.max().x(), box.max().z())};
}

struct Built {
  House house;
  BuiltNavGraph graph;
};

Built buildFor(uint64_t seed, const NavGraphBuildConfig& config = {}) {
  Built b{generateHouse(seed, HouseConfig{}), {}};
  const sim::RayTracer tracer(b.house.mesh);
  b.graph = buildNavGraph(b.house.semantics, tracer, config, seed * 7 + 1);
  return b;
}

TEST(NavGraphBuilderTest, NodesCoverRoomsAtTripodHeight) {
  const NavGraphBuildConfig config;
  for (uint64_t seed : {1u, 2u, 3u}) {
    const Built b = buildFor(seed);
    const auto& semantics = b.house.semantics;
    const data::NavGraph& g = b.graph.graph;
    ASSERT_GT(g.numNodes(), 5) << "seed " << seed;
    ASSERT_EQ(b.graph.placement.size(), static_cast<size_t>(g.numNodes()));
    std::vector<int> perRoom(semantics.rooms.size(), 0);
    for (int i = 0; i < g.numNodes(); ++i) {
      const Vec3f p = g.node(i).position;
      const int room = b.graph.room[static_cast<size_t>(i)];
      ASSERT_GE(room, 0);
      const sim::Room& r = semantics.rooms[static_cast<size_t>(room)];
      ++perRoom[static_cast<size_t>(room)];
      EXPECT_TRUE(isHex32(g.node(i).id)) << g.node(i).id;
      // tripod camera height above the room's floor
      EXPECT_GE(p.y() - r.floor_y, config.min_camera_height - 1e-4f);
      EXPECT_LE(p.y() - r.floor_y, config.max_camera_height + 1e-4f);
      const Vec2f xz(p.x(), p.z());
      if (b.graph.placement[static_cast<size_t>(i)] ==
          NodePlacement::kDoorway) {
        // on a doorway of its room
        bool onDoor = false;
        for (const auto& d : semantics.doors)
          if ((d.room_a == room || d.room_b == room) &&
              (Vec2f(d.center.x(), d.center.z()) - xz).norm() < 1e-3f)
            onDoor = true;
        EXPECT_TRUE(onDoor) << "doorway node " << i;
        continue;
      }
      // inside its room, away from the walls
      const float margin = 0.5f * config.wall_margin - 1e-3f;
      EXPECT_GE(xz.x(), r.footprint.min().x() + margin);
      EXPECT_LE(xz.x(), r.footprint.max().x() - margin);
      EXPECT_GE(xz.y(), r.footprint.min().y() + margin);
      EXPECT_LE(xz.y(), r.footprint.max().y() - margin);
      // room nodes stand clear of furniture (furniture nodes are over it)
      if (b.graph.placement[static_cast<size_t>(i)] == NodePlacement::kRoom) {
        for (const auto& o : semantics.objects) {
          const bool standing = o.bounds.min().y() < r.floor_y + 0.5f &&
                                o.bounds.max().y() > r.floor_y + 0.05f;
          if (!standing) continue;
          const auto grown = Eigen::AlignedBox2f(
              footprint(o.bounds).min() -
                  Vec2f::Constant(config.object_clearance - 0.01f),
              footprint(o.bounds).max() +
                  Vec2f::Constant(config.object_clearance - 0.01f));
          EXPECT_FALSE(grown.contains(xz))
              << "node " << i << " in a " << o.category;
        }
      }
      if (b.graph.placement[static_cast<size_t>(i)] ==
          NodePlacement::kFurniture) {
        bool over = false;
        for (const auto& o : semantics.objects)
          over = over || footprint(o.bounds).contains(xz);
        EXPECT_TRUE(over) << "furniture node " << i << " is over nothing";
      }
    }
    // every room has a panorama, and no two are closer than the separation
    for (size_t r = 0; r < perRoom.size(); ++r)
      EXPECT_GT(perRoom[r], 0)
          << semantics.rooms[r].type << " " << r << ", seed " << seed;
    for (int a = 0; a < g.numNodes(); ++a)
      for (int b2 = a + 1; b2 < g.numNodes(); ++b2)
        EXPECT_GE(horizontalDistance(g.node(a).position, g.node(b2).position),
                  config.min_node_separation - 1e-4f);
  }
}

TEST(NavGraphBuilderTest, EdgesAreShortAndHaveLineOfSight) {
  const NavGraphBuildConfig config;
  int64_t nodes = 0;
  int64_t largest = 0;
  for (uint64_t seed : {4u, 5u, 6u, 7u}) {
    const Built b = buildFor(seed);
    const sim::RayTracer tracer(b.house.mesh);
    const data::NavGraph& g = b.graph.graph;
    ASSERT_GT(g.numEdges(), g.numNodes() / 2);
    for (const auto& [a, c] : g.edges()) {
      const Vec3f pa = g.node(a).position;
      const Vec3f pc = g.node(c).position;
      EXPECT_LE(horizontalDistance(pa, pc), config.max_edge_length + 1e-4f);
      EXPECT_TRUE(tracer.visible(pa, pc)) << "edge " << a << "-" << c;
    }
    // a wall between two nodes means no edge: some near pairs are blocked
    int blocked = 0;
    for (int a = 0; a < g.numNodes(); ++a)
      for (int c = a + 1; c < g.numNodes(); ++c)
        if (horizontalDistance(g.node(a).position, g.node(c).position) <
                config.max_edge_length &&
            !tracer.visible(g.node(a).position, g.node(c).position)) {
          ++blocked;
          EXPECT_FALSE(g.adjacent(a, c));
        }
    EXPECT_GT(blocked, 0) << "walls should hide some nearby panoramas";
    const auto sizes = componentSizes(g);
    nodes += g.numNodes();
    largest += sizes.front();
  }
  // R2R graphs are connected; ours are, up to the odd isolated room
  EXPECT_GE(static_cast<double>(largest) / static_cast<double>(nodes), 0.85);
}

TEST(NavGraphBuilderTest, DeterministicPerSeed) {
  const Built a = buildFor(11);
  const Built b = buildFor(11);
  ASSERT_EQ(a.graph.graph.numNodes(), b.graph.graph.numNodes());
  for (int i = 0; i < a.graph.graph.numNodes(); ++i) {
    EXPECT_EQ(a.graph.graph.node(i).id, b.graph.graph.node(i).id);
    EXPECT_EQ(a.graph.graph.node(i).position, b.graph.graph.node(i).position);
  }
  EXPECT_EQ(a.graph.graph.edges(), b.graph.graph.edges());

  House house = generateHouse(11, HouseConfig{});
  const sim::RayTracer tracer(house.mesh);
  const BuiltNavGraph other = buildNavGraph(house.semantics, tracer, {}, 999);
  EXPECT_NE(other.graph.node(0).id, a.graph.graph.node(0).id);
}

// ---------------------------------------------------------------------------
// hand-made rooms: a hole in the floor, a large table
// ---------------------------------------------------------------------------

void addQuad(sim::TriangleMesh& mesh, const Vec3f& a, const Vec3f& b,
             const Vec3f& c, const Vec3f& d) {
  const auto base = static_cast<uint32_t>(mesh.positions.size());
  for (const Vec3f& p : {a, b, c, d}) mesh.positions.push_back(p);
  for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) mesh.indices.push_back(base + i);
}

void addFloor(sim::TriangleMesh& mesh, float x0, float z0, float x1, float z1) {
  addQuad(mesh, {x0, 0, z1}, {x1, 0, z1}, {x1, 0, z0}, {x0, 0, z0});
}

sim::SceneSemantics oneRoom(float size) {
  sim::SceneSemantics s;
  sim::Room r;
  r.id = 0;
  r.type = "living room";
  r.footprint = Eigen::AlignedBox2f(Vec2f(0, 0), Vec2f(size, size));
  s.rooms.push_back(r);
  return s;
}

TEST(NavGraphBuilderTest, PlacesANodeOverAFloorHole) {
  // a 6 x 6 m floor with a 0.8 x 0.8 m hole centred at (2.0, 4.0)
  sim::TriangleMesh mesh;
  addFloor(mesh, 0, 0, 6, 3.6f);
  addFloor(mesh, 0, 4.4f, 6, 6);
  addFloor(mesh, 0, 3.6f, 1.6f, 4.4f);
  addFloor(mesh, 2.4f, 3.6f, 6, 4.4f);
  const sim::RayTracer tracer(mesh);
  NavGraphBuildConfig config;
  config.hole_node_probability = 1.0f;
  const BuiltNavGraph built = buildNavGraph(oneRoom(6), tracer, config, 3);
  EXPECT_EQ(built.holes_found, 1);
  int holes = 0;
  for (int i = 0; i < built.graph.numNodes(); ++i) {
    if (built.placement[static_cast<size_t>(i)] != NodePlacement::kHole)
      continue;
    ++holes;
    const Vec3f p = built.graph.node(i).position;
    EXPECT_NEAR(p.x(), 2.0f, 0.15f);
    EXPECT_NEAR(p.z(), 4.0f, 0.15f);
  }
  EXPECT_EQ(holes, 1);

  config.hole_node_probability = 0.0f;
  const BuiltNavGraph none = buildNavGraph(oneRoom(6), tracer, config, 3);
  for (const NodePlacement p : none.placement)
    EXPECT_NE(p, NodePlacement::kHole);
}

TEST(NavGraphBuilderTest, NodesOverALargeTableStayOnlyWhenAllowed) {
  sim::TriangleMesh mesh;
  addFloor(mesh, 0, 0, 8, 8);
  sim::SceneSemantics semantics = oneRoom(8);
  // a 2.8 x 2.8 m table in the middle: several grid nodes fall on it
  sim::SemanticObject table;
  table.id = 0;
  table.category = "table";
  table.color = "wooden";
  table.room = 0;
  table.bounds =
      Eigen::AlignedBox3f(Vec3f(2.6f, 0.0f, 2.6f), Vec3f(5.4f, 0.75f, 5.4f));
  semantics.objects.push_back(table);
  const sim::RayTracer tracer(mesh);
  const Eigen::AlignedBox2f top = footprint(table.bounds);

  NavGraphBuildConfig config;
  config.spacing_jitter = 0.0f;
  config.furniture_node_probability = 1.0f;
  const BuiltNavGraph kept = buildNavGraph(semantics, tracer, config, 5);
  int over = 0;
  for (int i = 0; i < kept.graph.numNodes(); ++i) {
    const Vec3f p = kept.graph.node(i).position;
    if (top.contains(Vec2f(p.x(), p.z()))) {
      ++over;
      EXPECT_EQ(kept.placement[static_cast<size_t>(i)],
                NodePlacement::kFurniture);
    }
  }
  EXPECT_GT(over, 0);

  config.furniture_node_probability = 0.0f;
  const BuiltNavGraph pushed = buildNavGraph(semantics, tracer, config, 5);
  for (int i = 0; i < pushed.graph.numNodes(); ++i) {
    const Vec3f p = pushed.graph.node(i).position;
    EXPECT_FALSE(top.contains(Vec2f(p.x(), p.z()))) << "node " << i;
    EXPECT_NE(pushed.placement[static_cast<size_t>(i)],
              NodePlacement::kFurniture);
  }
}

TEST(NavGraphBuilderTest, NoRoomsIsAnError) {
  sim::TriangleMesh mesh;
  addFloor(mesh, 0, 0, 4, 4);
  const sim::RayTracer tracer(mesh);
  EXPECT_THROW(buildNavGraph(sim::SceneSemantics{}, tracer, {}, 1),
               std::invalid_argument);
}

}  // namespace
}  // namespace vln::world
