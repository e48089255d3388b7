// Mesh building for procedural houses: primitives with lighting baked into
// vertex colours, and the house structure (floors, ceilings, wall faces with
// doorways, skirting, the exterior shell).
//
// Walls are built as faces, not boxes: each room gets the four inner faces of
// its own walls (inset by half the wall thickness from the cell), doorways
// get jambs, a lintel and a threshold, and the outline gets an exterior
// face. The faces of a room meet exactly at its corners, so the inside is
// closed, and no floor lies inside a wall (a navmesh never finds a walkable
// strip there).

// First of all includes: no FMA contraction (see the header).
#include "world/HouseFpContract.h"

#include <algorithm>
#include <cmath>

#include "common/Check.h"
#include "world/HouseBuilder.h"

namespace vln::world::house {

// ===========================================================================
// exact unit circle
// ===========================================================================

std::array<float, 2> unitCircle(int k, int n) {
  // cos/sin of the first quadrant's steps, from square roots (IEEE-exact)
  // so that every machine builds identical round shapes
  static const float c45 = std::sqrt(0.5f);
  static const float c30 = std::sqrt(0.75f);
  static const float c22 = std::sqrt((2.0f + std::sqrt(2.0f)) / 4.0f);
  static const float s22 = std::sqrt((2.0f - std::sqrt(2.0f)) / 4.0f);
  int perQuadrant = 0;
  const float* cosTable = nullptr;
  const float* sinTable = nullptr;
  static const float cos4[1] = {1.0f}, sin4[1] = {0.0f};
  static const float cos8[2] = {1.0f, c45}, sin8[2] = {0.0f, c45};
  static const float cos12[3] = {1.0f, c30, 0.5f}, sin12[3] = {0.0f, 0.5f, c30};
  static const float cos16[4] = {1.0f, c22, c45, s22},
                     sin16[4] = {0.0f, s22, c45, c22};
  switch (n) {
    case 4:
      perQuadrant = 1;
      cosTable = cos4;
      sinTable = sin4;
      break;
    case 8:
      perQuadrant = 2;
      cosTable = cos8;
      sinTable = sin8;
      break;
    case 12:
      perQuadrant = 3;
      cosTable = cos12;
      sinTable = sin12;
      break;
    case 16:
      perQuadrant = 4;
      cosTable = cos16;
      sinTable = sin16;
      break;
    default:
      assertFailed("unitCircle: n is 4, 8, 12 or 16", __FILE__, __LINE__);
  }
  const int j = ((k % n) + n) % n;
  const int quadrant = j / perQuadrant;
  const float c = cosTable[j % perQuadrant];
  const float s = sinTable[j % perQuadrant];
  switch (quadrant) {
    case 0:
      return {c, s};
    case 1:
      return {-s, c};
    case 2:
      return {-c, -s};
    default:
      return {s, -c};
  }
}

// ===========================================================================
// MeshBuilder
// ===========================================================================

namespace {

// A warm key light from above one side and a weak fill from the other; the
// constants are chosen by eye so that wall orientations read differently.
const Vec3f kKeyLight = Vec3f(0.55f, 0.75f, 0.35f).normalized();
const Vec3f kFillLight = Vec3f(-0.6f, 0.3f, -0.5f).normalized();
constexpr float kAmbient = 0.58f;
constexpr float kKeyWeight = 0.32f;
constexpr float kFillWeight = 0.14f;
constexpr float kBounceWeight = 0.24f;  // light reflected up from the floor

float lightOf(const Vec3f& n) {
  return kAmbient + kKeyWeight * std::max(0.0f, n.dot(kKeyLight)) +
         kFillWeight * std::max(0.0f, n.dot(kFillLight)) +
         kBounceWeight * std::max(0.0f, -n.y());
}

uint8_t toByte(float value) {
  return static_cast<uint8_t>(std::clamp(value + 0.5f, 0.0f, 255.0f));
}

// furniture darkens towards the floor (contact shadow), fully lit from 35 cm
float contactShade(float y) {
  return 0.72f + 0.28f * std::min(1.0f, std::max(0.0f, y) / 0.35f);
}

}  // namespace

MeshBuilder::MeshBuilder(TriangleMesh& mesh, bool withUvs)
    : mesh_(mesh), withUvs_(withUvs) {}

uint32_t MeshBuilder::vertex(const Vec3f& p, const Vec3f& normal,
                             const Rgb8& color, Surface surface, float shade) {
  const float light = lightOf(normal) * shade;
  mesh_.positions.push_back(p);
  mesh_.colors.push_back({toByte(color[0] * light * tint_[0]),
                          toByte(color[1] * light * tint_[1]),
                          toByte(color[2] * light * tint_[2])});
  if (withUvs_) {
    // planar projection along the normal's dominant axis, in texture repeats
    const float period = surfacePeriod(surface);
    const Vec3f a = normal.cwiseAbs();
    Vec2f uv;
    if (a.y() >= a.x() && a.y() >= a.z())
      uv = Vec2f(p.x(), p.z());
    else if (a.x() >= a.z())
      uv = Vec2f(p.z(), 0.0f - p.y());  // 0 - y: no -0 at floor level
    else
      uv = Vec2f(p.x(), 0.0f - p.y());
    mesh_.uvs.push_back(uv / period);
  }
  return static_cast<uint32_t>(mesh_.positions.size() - 1);
}

void MeshBuilder::triangle(uint32_t a, uint32_t b, uint32_t c,
                           Surface surface) {
  mesh_.indices.insert(mesh_.indices.end(), {a, b, c});
  mesh_.triangle_material.push_back(static_cast<int32_t>(surface));
  mesh_.triangle_object.push_back(object_);
}

void MeshBuilder::quad(const std::array<Vec3f, 4>& corners, const Vec3f& normal,
                       const Rgb8& color, Surface surface,
                       const std::array<float, 4>& shade) {
  uint32_t v[4];
  for (int k = 0; k < 4; ++k)
    v[k] = vertex(corners[k], normal, color, surface, shade[k]);
  triangle(v[0], v[1], v[2], surface);
  triangle(v[0], v[2], v[3], surface);
}

void MeshBuilder::part(const Part& part, unsigned skipFaces) {
  switch (part.shape) {
    case Shape::kBox:
      box(part, skipFaces);
      break;
    case Shape::kSphere:
      sphere(part);
      break;
    default:
      revolve(part);
      break;
  }
}

void MeshBuilder::box(const Part& part, unsigned skipFaces) {
  const Vec3f& lo = part.box.min();
  const Vec3f& hi = part.box.max();
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      if (skipFaces & (1u << (2 * axis + side))) continue;
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      const float plane = side ? hi[axis] : lo[axis];
      std::array<Vec3f, 4> c;
      const float cu[4] = {lo[u], hi[u], hi[u], lo[u]};
      const float cv[4] = {lo[v], lo[v], hi[v], hi[v]};
      for (int k = 0; k < 4; ++k) {
        c[k][axis] = plane;
        c[k][u] = cu[k];
        c[k][v] = cv[k];
      }
      if (!side) std::swap(c[1], c[3]);
      Vec3f normal = Vec3f::Zero();
      normal[axis] = side ? 1.0f : -1.0f;
      std::array<float, 4> shade;
      for (int k = 0; k < 4; ++k) shade[k] = contactShade(c[k].y());
      quad(c, normal, part.color, part.surface, shade);
    }
  }
}

// Cylinders, cones and frustums: a ring of `n` segments around the axis,
// smooth-shaded sides and flat caps.
void MeshBuilder::revolve(const Part& part) {
  const Vec3f lo = part.box.min(), hi = part.box.max();
  int axis = 1;
  if (part.shape == Shape::kCylinderX) axis = 0;
  if (part.shape == Shape::kCylinderZ) axis = 2;
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  const Vec3f center = 0.5f * (lo + hi);
  const float ru = 0.5f * (hi[u] - lo[u]), rv = 0.5f * (hi[v] - lo[v]);
  const int n =
      std::max(ru, rv) > 0.12f ? 16 : (std::max(ru, rv) > 0.04f ? 12 : 8);
  const float topScale = part.shape == Shape::kConeY      ? 0.0f
                         : part.shape == Shape::kFrustumY ? 0.5f
                                                          : 1.0f;
  Vec3f axisDir = Vec3f::Zero();
  axisDir[axis] = 1.0f;

  auto ringPoint = [&](int k, float scale, float at) {
    const auto cs = unitCircle(k, n);
    Vec3f p = center;
    p[axis] = at;
    p[u] += scale * ru * cs[0];
    p[v] += scale * rv * cs[1];
    return p;
  };
  auto radial = [&](int k) {
    const auto cs = unitCircle(k, n);
    Vec3f d = Vec3f::Zero();
    // normal of an ellipse: gradient of (u/ru)^2 + (v/rv)^2
    d[u] = cs[0] / std::max(ru, 1e-4f);
    d[v] = cs[1] / std::max(rv, 1e-4f);
    // a cone's side leans towards its axis
    d.normalize();
    if (topScale < 1.0f) {
      const float slope = (1.0f - topScale) * std::max(ru, rv) /
                          std::max(hi[axis] - lo[axis], 1e-4f);
      d = (d + slope * axisDir).normalized();
    }
    return d;
  };

  // side: shared vertices per ring for smooth shading
  std::vector<uint32_t> bottom(n), top(n);
  for (int k = 0; k < n; ++k) {
    const Vec3f normal = radial(k);
    const Vec3f pb = ringPoint(k, 1.0f, lo[axis]);
    const Vec3f pt = ringPoint(k, topScale, hi[axis]);
    bottom[k] =
        vertex(pb, normal, part.color, part.surface, contactShade(pb.y()));
    top[k] = vertex(pt, normal, part.color, part.surface, contactShade(pt.y()));
  }
  for (int k = 0; k < n; ++k) {
    const int k1 = (k + 1) % n;
    triangle(bottom[k], bottom[k1], top[k1], part.surface);
    if (topScale > 0.0f) triangle(bottom[k], top[k1], top[k], part.surface);
  }
  // caps: fans around the centre, facing away from the shape
  auto cap = [&](float at, float scale, float sign) {
    Vec3f c = center;
    c[axis] = at;
    const Vec3f normal = sign * axisDir;
    const uint32_t mid =
        vertex(c, normal, part.color, part.surface, contactShade(c.y()));
    std::vector<uint32_t> ring(n);
    for (int k = 0; k < n; ++k) {
      const Vec3f p = ringPoint(k, scale, at);
      ring[k] =
          vertex(p, normal, part.color, part.surface, contactShade(p.y()));
    }
    for (int k = 0; k < n; ++k) {
      const int k1 = (k + 1) % n;
      if (sign > 0)
        triangle(mid, ring[k], ring[k1], part.surface);
      else
        triangle(mid, ring[k1], ring[k], part.surface);
    }
  };
  cap(lo[axis], 1.0f, -1.0f);
  if (topScale > 0.0f) cap(hi[axis], topScale, 1.0f);
}

// Ellipsoid with 8 longitudes and 45-degree latitude bands; longitudes turn
// from +z towards +x like revolve()'s rings, so windings match.
void MeshBuilder::sphere(const Part& part) {
  constexpr int kSegments = 8;
  const Vec3f center = part.box.center();
  const Vec3f radius = 0.5f * part.box.sizes();
  // latitude lat = 0 (south pole) .. 4 (north pole): polar angle 180 - 45 lat
  // degrees, so height = -cos(45 lat) and ring radius = sin(45 lat)
  std::vector<std::vector<uint32_t>> rings;
  for (int lat = 0; lat <= 4; ++lat) {
    const auto cs = unitCircle(lat, 8);
    const float y = -cs[0];
    const float r = std::max(0.0f, cs[1]);
    std::vector<uint32_t> ring;
    const int count = (lat == 0 || lat == 4) ? 1 : kSegments;
    for (int k = 0; k < count; ++k) {
      const auto lon = unitCircle(k, kSegments);
      const Vec3f unit(r * lon[1], y, r * lon[0]);
      const Vec3f p = center + unit.cwiseProduct(radius);
      const Vec3f normal =
          unit.cwiseQuotient(radius.cwiseMax(1e-4f)).normalized();
      ring.push_back(
          vertex(p, normal, part.color, part.surface, contactShade(p.y())));
    }
    rings.push_back(std::move(ring));
  }
  for (int lat = 0; lat < 4; ++lat) {
    const auto& a = rings[lat];
    const auto& b = rings[lat + 1];
    for (int k = 0; k < kSegments; ++k) {
      const int k1 = (k + 1) % kSegments;
      if (a.size() == 1) {
        triangle(a[0], b[k1], b[k], part.surface);
      } else if (b.size() == 1) {
        triangle(a[k], a[k1], b[0], part.surface);
      } else {
        triangle(a[k], a[k1], b[k1], part.surface);
        triangle(a[k], b[k1], b[k], part.surface);
      }
    }
  }
}

// ===========================================================================
// house structure
// ===========================================================================

namespace {

constexpr float kSkirting = 0.08f;  // skirting board height, metres
constexpr float kAoBand = 0.3f;     // width of corner darkening, metres
constexpr float kCornerShade = 0.84f;

float cm(int value) { return static_cast<float>(value) / 100.0f; }

bool near(float a, float b) { return std::abs(a - b) < 1e-3f; }

// Whether the point (x, z) in centimetres lies strictly inside some room.
bool insideHouse(const FloorPlan& plan, int x, int z) {
  for (const PlanRoom& room : plan.rooms)
    if (x > room.cell.x0 && x < room.cell.x1 && z > room.cell.z0 &&
        z < room.cell.z1)
      return true;
  return false;
}

// One side of a room's interior, as seen from inside the room.
struct WallSide {
  int axis = 2;                // axis of the face normal: 0 (x) or 2 (z)
  int sign = 1;                // the normal points into the room
  float plane = 0.0f;          // face position along `axis`
  float lo = 0.0f, hi = 0.0f;  // extent along the wall
  std::vector<std::array<float, 2>> openings;  // door spans along the wall
};

class StructureBuilder {
 public:
  StructureBuilder(const FloorPlan& plan, const HouseStyle& style,
                   const HouseConfig& config,
                   const std::vector<Eigen::AlignedBox2f>& holes,
                   MeshBuilder& out)
      : plan_(plan),
        style_(style),
        holes_(holes),
        out_(out),
        t_(config.wall_thickness),
        height_(config.wall_height),
        doorTop_(std::min(2.1f, config.wall_height - 0.15f)) {}

  void run() {
    out_.setObject(-1);
    for (size_t i = 0; i < plan_.rooms.size(); ++i) room(static_cast<int>(i));
    for (const PlanDoor& door : plan_.doors) doorway(door);
    exterior();
  }

 private:
  // ---- rooms ---------------------------------------------------------------
  void room(int index) {
    const RectCm& cell = plan_.rooms[index].cell;
    const RoomStyle& style = style_.rooms[index];
    out_.setTint(style.tint);
    const float h = 0.5f * t_;
    const float x0 = cm(cell.x0) + h, x1 = cm(cell.x1) - h;
    const float z0 = cm(cell.z0) + h, z1 = cm(cell.z1) - h;

    // darker where floor and ceiling meet the walls
    auto edgeShade = [=](float shade) {
      return [=](const Vec3f& p) {
        const bool atWall = near(p.x(), x0) || near(p.x(), x1) ||
                            near(p.z(), z0) || near(p.z(), z1);
        return atWall ? shade : 1.0f;
      };
    };
    std::vector<float> cutsX{x0 + kAoBand, x1 - kAoBand};
    std::vector<float> cutsZ{z0 + kAoBand, z1 - kAoBand};
    // holes in the floor grid's (u, v) = (z, x) plane
    std::vector<Eigen::AlignedBox2f> holesZx;
    for (const auto& hole : holes_) {
      if (hole.max().x() <= x0 || hole.min().x() >= x1 ||
          hole.max().y() <= z0 || hole.min().y() >= z1)
        continue;
      cutsX.push_back(hole.min().x());
      cutsX.push_back(hole.max().x());
      cutsZ.push_back(hole.min().y());
      cutsZ.push_back(hole.max().y());
      holesZx.emplace_back(Vec2f(hole.min().y(), hole.min().x()),
                           Vec2f(hole.max().y(), hole.max().x()));
    }
    out_.grid(Vec3f(x0, 0.0f, z0), Vec3f(x1, 0.0f, z1), /*axis=*/1, /*sign=*/1,
              cutsZ, cutsX, style.floor, style.floor_surface, edgeShade(0.8f),
              holesZx);
    out_.grid(Vec3f(x0, height_, z0), Vec3f(x1, height_, z1), /*axis=*/1,
              /*sign=*/-1, cutsZ, cutsX, style.ceiling, Surface::kPlaster,
              edgeShade(0.86f));

    // the four inner wall faces
    std::array<WallSide, 4> sides;
    sides[0] = {2, +1, z0, x0, x1, {}};  // wall at min z, facing +z
    sides[1] = {2, -1, z1, x0, x1, {}};  // wall at max z, facing -z
    sides[2] = {0, +1, x0, z0, z1, {}};  // wall at min x, facing +x
    sides[3] = {0, -1, x1, z0, z1, {}};  // wall at max x, facing -x
    const int lines[4] = {cell.z0, cell.z1, cell.x0, cell.x1};
    for (const PlanDoor& door : plan_.doors) {
      if (door.room_a != index && door.room_b != index) continue;
      for (int s = 0; s < 4; ++s) {
        const bool alongX = sides[s].axis == 2;
        if (door.along_x != alongX || door.line_cm != lines[s]) continue;
        const auto span = doorSpanCm(door);
        sides[s].openings.push_back({cm(span[0]), cm(span[1])});
      }
    }
    for (WallSide& side : sides) wall(side, style);
  }

  // A face of the wall: [a, b] along it, [y0, y1] up.
  template <class ShadeFn>
  void wallRect(const WallSide& side, float a, float b, float y0, float y1,
                const Rgb8& color, Surface surface, ShadeFn shade) {
    const std::vector<float> alongCuts{side.lo + kAoBand, side.hi - kAoBand};
    const std::vector<float> heightCuts{height_ - kAoBand, kSkirting + kAoBand};
    if (side.axis == 2) {
      out_.grid(Vec3f(a, y0, side.plane), Vec3f(b, y1, side.plane), 2,
                side.sign, alongCuts, heightCuts, color, surface, shade);
    } else {
      out_.grid(Vec3f(side.plane, y0, a), Vec3f(side.plane, y1, b), 0,
                side.sign, heightCuts, alongCuts, color, surface, shade);
    }
  }

  void wall(WallSide& side, const RoomStyle& style) {
    std::sort(side.openings.begin(), side.openings.end());
    const float lo = side.lo, hi = side.hi;
    const float top = height_;
    const float doorTop = doorTop_;
    auto shade = [&side, lo, hi, top](const Vec3f& p) {
      const float along = side.axis == 2 ? p.x() : p.z();
      float s = 1.0f;
      if (near(along, lo) || near(along, hi)) s *= kCornerShade;
      if (near(p.y(), top)) s *= 0.9f;
      if (near(p.y(), kSkirting) || near(p.y(), 0.0f)) s *= 0.88f;
      return s;
    };
    auto solid = [&](float a, float b) {
      if (b - a < 1e-4f) return;
      wallRect(side, a, b, 0.0f, kSkirting, style.trim, Surface::kPlain, shade);
      wallRect(side, a, b, kSkirting, top, style.wall, style.wall_surface,
               shade);
    };
    float cursor = lo;
    for (const auto& opening : side.openings) {
      solid(cursor, opening[0]);
      wallRect(side, opening[0], opening[1], doorTop, top, style.wall,
               style.wall_surface, shade);
      cursor = opening[1];
    }
    solid(cursor, hi);
  }

  // ---- doorways: threshold, jambs, lintel -----------------------------------
  void doorway(const PlanDoor& door) {
    const RoomStyle& style = style_.rooms[door.room_a];
    out_.setTint(style.tint);
    const auto span = doorSpanCm(door);
    const float a = cm(span[0]), b = cm(span[1]);
    const float line = cm(door.line_cm);
    const float w0 = line - 0.5f * t_, w1 = line + 0.5f * t_;
    auto flat = [](const Vec3f&) { return 1.0f; };
    // (along the opening, height, across the wall) -> world: the opening
    // runs along x or along z; its sides face along that axis
    auto at = [&](float along, float y, float across) {
      return door.along_x ? Vec3f(along, y, across) : Vec3f(across, y, along);
    };
    const int sideAxis = door.along_x ? 0 : 2;
    out_.grid(at(a, 0.0f, w0), at(b, 0.0f, w1), 1, +1, {}, {}, style.floor,
              style.floor_surface, flat);
    out_.grid(at(a, doorTop_, w0), at(b, doorTop_, w1), 1, -1, {}, {},
              style.trim, Surface::kPlain, flat);
    out_.grid(at(a, 0.0f, w0), at(a, doorTop_, w1), sideAxis, +1, {}, {},
              style.trim, Surface::kPlain, flat);
    out_.grid(at(b, 0.0f, w0), at(b, doorTop_, w1), sideAxis, -1, {}, {},
              style.trim, Surface::kPlain, flat);
  }

  // ---- exterior shell and wall tops
  // ------------------------------------------ For every stretch of a room edge
  // with no room across it: an outward face half a wall thickness out, and the
  // wall's top. Ends are extended at convex corners and shortened at concave
  // ones so the shell closes.
  void exterior() {
    out_.setTint({1.0f, 1.0f, 1.0f});
    const float h = 0.5f * t_;
    auto flat = [](const Vec3f&) { return 1.0f; };
    for (const PlanRoom& room : plan_.rooms) {
      const RectCm& c = room.cell;
      // top of this room's half of each wall (a ring inside the cell)
      const float x0 = cm(c.x0), x1 = cm(c.x1), z0 = cm(c.z0), z1 = cm(c.z1);
      const Rgb8 top = style_.exterior;
      out_.grid(Vec3f(x0, height_, z0), Vec3f(x1, height_, z0 + h), 1, 1, {},
                {}, top, Surface::kPlain, flat);
      out_.grid(Vec3f(x0, height_, z1 - h), Vec3f(x1, height_, z1), 1, 1, {},
                {}, top, Surface::kPlain, flat);
      out_.grid(Vec3f(x0, height_, z0 + h), Vec3f(x0 + h, height_, z1 - h), 1,
                1, {}, {}, top, Surface::kPlain, flat);
      out_.grid(Vec3f(x1 - h, height_, z0 + h), Vec3f(x1, height_, z1 - h), 1,
                1, {}, {}, top, Surface::kPlain, flat);

      // edges: (along_x, line, lo, hi, outward sign)
      struct Edge {
        bool alongX;
        int line, lo, hi, out;
      };
      const Edge edges[4] = {{true, c.z0, c.x0, c.x1, -1},
                             {true, c.z1, c.x0, c.x1, +1},
                             {false, c.x0, c.z0, c.z1, -1},
                             {false, c.x1, c.z0, c.z1, +1}};
      for (const Edge& e : edges) {
        // walk the edge in 10 cm steps (the plan grid), collecting stretches
        // whose outside neighbour is not a room
        int start = -1;
        for (int at = e.lo; at <= e.hi; at += 10) {
          bool open = false;
          if (at < e.hi) {
            const int mid = at + 5;
            const int across = e.line + e.out;
            open = e.alongX ? !insideHouse(plan_, mid, across)
                            : !insideHouse(plan_, across, mid);
          }
          if (open && start < 0) start = at;
          if (!open && start >= 0) {
            shell(e.alongX, e.line, start, at, e.out);
            start = -1;
          }
        }
      }
    }
  }

  // +h at a convex end, -h at a concave one, 0 where the outline goes on
  float endExtension(bool alongX, int line, int end, int direction,
                     int out) const {
    const int beyond = end + direction;
    const bool outsideSide = alongX ? insideHouse(plan_, beyond, line + out)
                                    : insideHouse(plan_, line + out, beyond);
    if (outsideSide) return -0.5f * t_;
    const bool insideSide = alongX ? insideHouse(plan_, beyond, line - out)
                                   : insideHouse(plan_, line - out, beyond);
    return insideSide ? 0.0f : 0.5f * t_;
  }

  void shell(bool alongX, int line, int lo, int hi, int out) {
    const float h = 0.5f * t_;
    const float a = cm(lo) - endExtension(alongX, line, lo, -1, out);
    const float b = cm(hi) + endExtension(alongX, line, hi, +1, out);
    const float plane = cm(line) + static_cast<float>(out) * h;
    const float inner = cm(line);
    auto flat = [](const Vec3f&) { return 1.0f; };
    const Rgb8 color = style_.exterior;
    // the outer half's top: strips along x take the corner squares, strips
    // along z stop at the cell so the two never overlap
    if (alongX) {
      out_.grid(Vec3f(a, height_, std::min(plane, inner)),
                Vec3f(b, height_, std::max(plane, inner)), 1, 1, {}, {}, color,
                Surface::kPlain, flat);
      out_.grid(Vec3f(a, 0.0f, plane), Vec3f(b, height_, plane), 2, out, {}, {},
                color, Surface::kPlaster, flat);
    } else {
      out_.grid(Vec3f(std::min(plane, inner), height_, cm(lo)),
                Vec3f(std::max(plane, inner), height_, cm(hi)), 1, 1, {}, {},
                color, Surface::kPlain, flat);
      out_.grid(Vec3f(plane, 0.0f, a), Vec3f(plane, height_, b), 0, out, {}, {},
                color, Surface::kPlaster, flat);
    }
  }

  const FloorPlan& plan_;
  const HouseStyle& style_;
  const std::vector<Eigen::AlignedBox2f>& holes_;
  MeshBuilder& out_;
  float t_;
  float height_;
  float doorTop_;
};

}  // namespace

void buildStructure(const FloorPlan& plan, const HouseStyle& style,
                    const HouseConfig& config,
                    const std::vector<Eigen::AlignedBox2f>& holes,
                    MeshBuilder& builder) {
  StructureBuilder(plan, style, config, holes, builder).run();
}

}  // namespace vln::world::house
