#include "sim/NavMesh.h"

#include <DetourAlloc.h>
#include <DetourCommon.h>
#include <DetourNavMesh.h>
#include <DetourNavMeshQuery.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <mutex>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>

#include "common/Check.h"
#include "common/FileIo.h"
#include "common/Random.h"
#include "sim/NavMeshBuild.h"

namespace vln::sim {

namespace {

// ===========================================================================
// constants
// ===========================================================================

// Half extents of the box in which Habitat-Sim's projectToPoly looks for the
// nearest polygon (PathFinder.cpp polyPickExt); used wherever Habitat snaps.
constexpr float kPickHalfExtents[3] = {2.0f, 4.0f, 2.0f};
// Habitat is_navigable: the snapped point must lie within 1 cm horizontally.
constexpr float kNavigableHorizontalTolerance = 1e-2f;
// Polygons below this area (m^2) are disabled, as Habitat's
// removeZeroAreaPolys does: walking into them crashes Detour queries.
constexpr float kMinPolygonArea = 1e-5f;
// moveAlongSurface visits at most this many polygons per step (Habitat).
constexpr int kMaxMovePolys = 256;
// A straight path must end this close to the snapped goal to count.
constexpr float kPathEndTolerance = 1e-3f;
// A move counts as unaltered when it ends this close (m) to its target.
constexpr float kNoSlideTolerance = 1e-4f;
// Habitat nudges moves that end on a seam between islands this far (m) into
// the polygon moveAlongSurface ended in.
constexpr float kThinWallNudge = 1e-4f;
// dtNodePool indexes nodes with 16 bits.
constexpr int kMaxQueryNodes = 65535;
// Loaded vertex coordinates beyond this (m) are corrupt: their squares would
// overflow the float distance tests inside Detour.
constexpr float kMaxCoordinate = 1e6f;

// "MSET" tile-set layout of the Recast demo, used by Habitat's .navmesh files.
constexpr int32_t kNavMeshSetMagic = 'M' << 24 | 'S' << 16 | 'E' << 8 | 'T';
constexpr int32_t kNavMeshSetVersion = 1;
static_assert(sizeof(dtTileRef) == 4,
              "Habitat's .navmesh layout assumes 32-bit Detour tile refs");
static_assert(sizeof(dtNavMeshParams) == 28,
              "dtNavMeshParams layout differs from Habitat's .navmesh files");
constexpr size_t kSetHeaderBytes =
    3 * sizeof(int32_t) + sizeof(dtNavMeshParams);
constexpr size_t kTileHeaderBytes = sizeof(dtTileRef) + sizeof(int32_t);

struct DtNavMeshDeleter {
  void operator()(dtNavMesh* p) const { dtFreeNavMesh(p); }
};
using DtNavMeshPtr = std::unique_ptr<dtNavMesh, DtNavMeshDeleter>;
struct DtQueryDeleter {
  void operator()(dtNavMeshQuery* p) const { dtFreeNavMeshQuery(p); }
};
using DtQueryPtr = std::unique_ptr<dtNavMeshQuery, DtQueryDeleter>;

using Triangle = std::array<Vec3f, 3>;

// ===========================================================================
// small helpers
// ===========================================================================

Vec3f vec(const float* p) { return {p[0], p[1], p[2]}; }

float triangleArea(const Triangle& t) {
  return 0.5f * (t[1] - t[0]).cross(t[2] - t[0]).norm();
}

// Calls f(Triangle) for each detail triangle of polygon `ip` of `tile`;
// detail indices below vertCount address polygon vertices, the rest the
// polygon's extra detail vertices.
template <class F>
void forEachDetailTriangle(const dtMeshTile& tile, int ip, F&& f) {
  const dtPoly& poly = tile.polys[ip];
  const dtPolyDetail& pd = tile.detailMeshes[ip];
  for (int j = 0; j < pd.triCount; ++j) {
    const unsigned char* t = &tile.detailTris[(pd.triBase + j) * 4];
    Triangle tri;
    for (int k = 0; k < 3; ++k) {
      tri[k] =
          t[k] < poly.vertCount
              ? vec(&tile.verts[poly.verts[t[k]] * 3])
              : vec(&tile.detailVerts[(pd.vertBase + t[k] - poly.vertCount) *
                                      3]);
    }
    f(tri);
  }
}

template <class T>
void appendRaw(std::string& out, const T& value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

template <class T>
T readRaw(const std::string& bytes, size_t offset) {
  T value;
  std::memcpy(&value, bytes.data() + offset, sizeof(T));
  return value;
}

// Where each array of a Detour tile lives inside its data blob (the same
// layout arithmetic as dtNavMesh::addTile).
struct TileLayout {
  dtMeshHeader header;
  int64_t bytes = 0;  // total size the header's counts require
  float* verts = nullptr;
  dtPoly* polys = nullptr;
  dtPolyDetail* details = nullptr;
  float* detailVerts = nullptr;
  unsigned char* detailTris = nullptr;
  dtBVNode* bvNodes = nullptr;
  dtOffMeshConnection* offMeshCons = nullptr;
};

// The layout of `data` (its header must be readable and its counts sane);
// pointers are only valid when layout.bytes <= the data size.
TileLayout tileLayout(unsigned char* data) {
  TileLayout t;
  std::memcpy(&t.header, data, sizeof(t.header));
  const dtMeshHeader& h = t.header;
  int64_t offset = dtAlign4(sizeof(dtMeshHeader));
  auto take = [&](int64_t size) {
    unsigned char* at = data + offset;
    offset += dtAlign4(static_cast<int>(size));
    return at;
  };
  t.verts = reinterpret_cast<float*>(take(int64_t{12} * h.vertCount));
  t.polys =
      reinterpret_cast<dtPoly*>(take(int64_t{sizeof(dtPoly)} * h.polyCount));
  take(int64_t{sizeof(dtLink)} * h.maxLinkCount);
  t.details = reinterpret_cast<dtPolyDetail*>(
      take(int64_t{sizeof(dtPolyDetail)} * h.detailMeshCount));
  t.detailVerts =
      reinterpret_cast<float*>(take(int64_t{12} * h.detailVertCount));
  t.detailTris = take(int64_t{4} * h.detailTriCount);
  t.bvNodes = reinterpret_cast<dtBVNode*>(
      take(int64_t{sizeof(dtBVNode)} * h.bvNodeCount));
  t.offMeshCons = reinterpret_cast<dtOffMeshConnection*>(
      take(int64_t{sizeof(dtOffMeshConnection)} * h.offMeshConCount));
  t.bytes = offset;
  return t;
}

// Checks that a tile's header counts fit its size and that every index and
// coordinate in it is usable, so that a corrupt file cannot make Detour read
// out of bounds or divide its way to NaN. Returns an empty string when the
// tile is sound, else the reason.
std::string tileDataProblem(unsigned char* data, int size) {
  if (size < static_cast<int>(sizeof(dtMeshHeader)))
    return strCat("tile of ", size, " bytes is smaller than its header");
  dtMeshHeader h;
  std::memcpy(&h, data, sizeof(h));
  if (h.magic != DT_NAVMESH_MAGIC) return "tile has a bad magic number";
  if (h.version != DT_NAVMESH_VERSION)
    return strCat("tile has Detour data version ", h.version, ", expected ",
                  DT_NAVMESH_VERSION);
  const int counts[] = {h.polyCount,       h.vertCount,       h.maxLinkCount,
                        h.detailMeshCount, h.detailVertCount, h.detailTriCount,
                        h.bvNodeCount,     h.offMeshConCount, h.offMeshBase};
  for (int c : counts)
    if (c < 0 || c > (1 << 24)) return "tile has an impossible element count";
  if (h.detailMeshCount > h.polyCount)
    return "tile has more detail meshes than polygons";
  const TileLayout t = tileLayout(data);
  if (t.bytes > size)
    return strCat("tile header describes ", t.bytes, " bytes but the tile has ",
                  size);

  // coordinates: finite and small enough that squared distances stay finite
  auto badCoordinate = [](const float* v, int n) {
    for (int i = 0; i < 3 * n; ++i)
      if (!(std::abs(v[i]) < kMaxCoordinate)) return true;
    return false;
  };
  if (badCoordinate(t.verts, h.vertCount) ||
      badCoordinate(t.detailVerts, h.detailVertCount))
    return "tile has non-finite or huge vertex coordinates";

  // polygon vertices and internal neighbours
  for (int i = 0; i < h.polyCount; ++i) {
    const dtPoly& p = t.polys[i];
    if (p.vertCount > DT_VERTS_PER_POLYGON)
      return strCat("polygon ", i, " has ", int{p.vertCount}, " vertices");
    for (int j = 0; j < p.vertCount; ++j) {
      if (p.verts[j] >= h.vertCount)
        return strCat("polygon ", i, " uses vertex ", p.verts[j], " of ",
                      h.vertCount);
      const bool external = (p.neis[j] & DT_EXT_LINK) != 0;
      if (!external && p.neis[j] > h.polyCount)
        return strCat("polygon ", i, " has neighbour ", p.neis[j], " of ",
                      h.polyCount);
    }
  }
  // every ground polygon has a non-empty detail mesh inside the arrays
  for (int i = 0; i < h.polyCount; ++i) {
    if (t.polys[i].getType() == DT_POLYTYPE_OFFMESH_CONNECTION) continue;
    if (i >= h.detailMeshCount)
      return strCat("ground polygon ", i, " has no detail mesh");
    const dtPolyDetail& d = t.details[i];
    if (t.polys[i].vertCount < 3 || d.triCount == 0)
      return strCat("ground polygon ", i, " is degenerate");
    if (int64_t{d.vertBase} + d.vertCount > h.detailVertCount ||
        int64_t{d.triBase} + d.triCount > h.detailTriCount)
      return strCat("detail mesh ", i, " exceeds the detail arrays");
    const int limit = t.polys[i].vertCount + d.vertCount;
    for (int k = 0; k < 4 * d.triCount; ++k)
      if (k % 4 != 3 && t.detailTris[4 * d.triBase + k] >= limit)
        return strCat("detail mesh ", i, " has a bad triangle index");
  }
  // off-mesh connections name their polygon
  if (int64_t{h.offMeshBase} + h.offMeshConCount > h.polyCount)
    return "tile has more off-mesh connections than polygons";
  for (int i = 0; i < h.offMeshConCount; ++i)
    if (int{t.offMeshCons[i].poly} >= h.polyCount)
      return strCat("off-mesh connection ", i, " names polygon ",
                    t.offMeshCons[i].poly);
  // bounding-volume leaves name polygons
  for (int i = 0; i < h.bvNodeCount; ++i)
    if (t.bvNodes[i].i >= h.polyCount || t.bvNodes[i].i < -h.bvNodeCount)
      return strCat("bounding-volume node ", i, " names polygon ",
                    t.bvNodes[i].i);
  return {};
}

// Detour's closestPointOnPoly dereferences a null pointer when no detail
// triangle of a polygon has an edge flagged as lying on the polygon outline
// (recastnavigation issues #394 and #656; Recast's flags can miss edges).
// Such polygons get every detail edge flagged, which the maintainers note is
// harmless: a false boundary only costs an extra distance test. Call on
// tiles that passed tileDataProblem().
void ensureDetailBoundaryEdges(unsigned char* data) {
  constexpr unsigned char kAllEdgesBoundary = DT_DETAIL_EDGE_BOUNDARY |
                                              DT_DETAIL_EDGE_BOUNDARY << 2 |
                                              DT_DETAIL_EDGE_BOUNDARY << 4;
  const TileLayout t = tileLayout(data);
  for (int i = 0; i < t.header.polyCount; ++i) {
    if (t.polys[i].getType() == DT_POLYTYPE_OFFMESH_CONNECTION) continue;
    const dtPolyDetail& d = t.details[i];
    unsigned char* flags = t.detailTris + 4 * d.triBase + 3;
    bool anyBoundary = false;
    for (int k = 0; k < d.triCount; ++k)
      anyBoundary = anyBoundary || (flags[4 * k] & kAllEdgesBoundary) != 0;
    if (!anyBoundary)
      for (int k = 0; k < d.triCount; ++k) flags[4 * k] |= kAllEdgesBoundary;
  }
}

}  // namespace

// ===========================================================================
// Impl: the Detour navmesh, its polygon tables and a pool of queries
// ===========================================================================

struct NavMesh::Impl {
  // Detour queries keep per-search state, so each thread borrows its own
  // together with scratch buffers sized for the longest possible path.
  struct QueryContext {
    DtQueryPtr query;
    std::vector<dtPolyRef> path;
    std::vector<float> straight;
  };

  // Returns its QueryContext to the pool when destroyed.
  class Lease {
   public:
    Lease(const Impl& owner, std::unique_ptr<QueryContext> context)
        : owner_(owner), context_(std::move(context)) {}
    ~Lease() { owner_.release(std::move(context_)); }
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    QueryContext& operator*() const { return *context_; }
    QueryContext* operator->() const { return context_.get(); }

   private:
    const Impl& owner_;
    std::unique_ptr<QueryContext> context_;
  };

  // A polygon found by a snap: its reference and the nearest point on it.
  struct Located {
    dtPolyRef ref = 0;
    Vec3f point = Vec3f::Zero();
  };

  NavMeshConfig config;
  DtNavMeshPtr mesh;
  dtQueryFilter filter;
  int maxNodes = 0;

  // per tile index: global index of its first polygon (-1: no tile)
  std::vector<int> tileBase;
  // per global polygon: island (-1 for disabled or off-mesh polygons)
  std::vector<int> polyIsland;
  int numPolys = 0;
  std::vector<float> islandAreas;
  float totalArea = 0.0f;
  // detail triangles grouped by island, inclusive prefix sums of their areas
  // and each island's [begin, end) range, for sampling and triangles()
  std::vector<Triangle> triangles;
  std::vector<double> cumulativeArea;
  std::vector<size_t> islandTriangleBegin;

  mutable std::mutex poolMutex;
  mutable std::vector<std::unique_ptr<QueryContext>> pool;

  Impl(DtNavMeshPtr navMesh, const NavMeshConfig& navConfig);

  Lease acquire() const;
  void release(std::unique_ptr<QueryContext> context) const;

  int globalIndex(dtPolyRef ref) const;
  int islandOf(dtPolyRef ref) const;
  std::optional<Located> locate(const dtNavMeshQuery& query, const Vec3f& p,
                                const float* halfExtents) const;
  std::optional<Located> locateNavigable(const dtNavMeshQuery& query,
                                         const Vec3f& p, float maxYDelta) const;
  bool walkable(const dtPoly& poly) const;
  float findCorners(QueryContext& context, const Vec3f& from, const Vec3f& to,
                    std::vector<Vec3f>* corners) const;

 private:
  void disableZeroAreaPolygons();
  void buildIslands();
};

NavMesh::Impl::Impl(DtNavMeshPtr navMesh, const NavMeshConfig& navConfig)
    : config(navConfig), mesh(std::move(navMesh)) {
  filter.setIncludeFlags(detail::kPolyFlagWalk);
  filter.setExcludeFlags(0);

  // global polygon numbering over all tiles
  const dtNavMesh& constMesh = *mesh;
  tileBase.assign(static_cast<size_t>(constMesh.getMaxTiles()), -1);
  for (int i = 0; i < constMesh.getMaxTiles(); ++i) {
    const dtMeshTile* tile = constMesh.getTile(i);
    if (tile == nullptr || tile->header == nullptr) continue;
    tileBase[static_cast<size_t>(i)] = numPolys;
    numPolys += tile->header->polyCount;
  }
  // A* never holds more nodes than there are polygons
  maxNodes = std::clamp(numPolys + 1, 64, kMaxQueryNodes);

  disableZeroAreaPolygons();
  buildIslands();
}

NavMesh::Impl::Lease NavMesh::Impl::acquire() const {
  {
    std::lock_guard<std::mutex> lock(poolMutex);
    if (!pool.empty()) {
      auto context = std::move(pool.back());
      pool.pop_back();
      return Lease(*this, std::move(context));
    }
  }
  // a new query is created outside the lock; init only reads the navmesh
  auto context = std::make_unique<QueryContext>();
  context->query.reset(dtAllocNavMeshQuery());
  VLN_CHECK_IO(context->query != nullptr,
               "NavMesh: out of memory allocating a Detour query");
  VLN_CHECK_IO(dtStatusSucceed(context->query->init(mesh.get(), maxNodes)),
               "NavMesh: cannot initialise a Detour query with ", maxNodes,
               " nodes");
  context->path.resize(static_cast<size_t>(maxNodes));
  // a straight path has at most one corner per portal plus both ends
  context->straight.resize(3 * (static_cast<size_t>(maxNodes) + 2));
  return Lease(*this, std::move(context));
}

void NavMesh::Impl::release(std::unique_ptr<QueryContext> context) const {
  std::lock_guard<std::mutex> lock(poolMutex);
  pool.push_back(std::move(context));
}

// dtQueryFilter::passFilter for non-virtual filters, which Detour defines
// inline in its own translation unit and so does not export.
bool NavMesh::Impl::walkable(const dtPoly& poly) const {
  return poly.getType() != DT_POLYTYPE_OFFMESH_CONNECTION &&
         (poly.flags & filter.getIncludeFlags()) != 0 &&
         (poly.flags & filter.getExcludeFlags()) == 0;
}

int NavMesh::Impl::globalIndex(dtPolyRef ref) const {
  const unsigned tile = mesh->decodePolyIdTile(ref);
  const unsigned poly = mesh->decodePolyIdPoly(ref);
  VLN_ASSERT(tile < tileBase.size() && tileBase[tile] >= 0);
  return tileBase[tile] + static_cast<int>(poly);
}

int NavMesh::Impl::islandOf(dtPolyRef ref) const {
  return polyIsland[static_cast<size_t>(globalIndex(ref))];
}

std::optional<NavMesh::Impl::Located> NavMesh::Impl::locate(
    const dtNavMeshQuery& query, const Vec3f& p,
    const float* halfExtents) const {
  Located result;
  const dtStatus status = query.findNearestPoly(
      p.data(), halfExtents, &filter, &result.ref, result.point.data());
  // success with ref 0 means "nothing in the box"
  if (dtStatusFailed(status) || result.ref == 0) return std::nullopt;
  return result;
}

std::optional<NavMesh::Impl::Located> NavMesh::Impl::locateNavigable(
    const dtNavMeshQuery& query, const Vec3f& p, float maxYDelta) const {
  // Habitat is_navigable: snap in the pick box, then require the snap to be
  // (nearly) vertical and within maxYDelta
  auto located = locate(query, p, kPickHalfExtents);
  if (!located) return std::nullopt;
  if (std::abs(located->point.y() - p.y()) > maxYDelta ||
      horizontalDistance(located->point, p) > kNavigableHorizontalTolerance)
    return std::nullopt;
  return located;
}

// Length of the shortest path between the snapped `from` and `to`, with its
// corners in `corners` when given; kUnreachable when there is none.
float NavMesh::Impl::findCorners(QueryContext& context, const Vec3f& from,
                                 const Vec3f& to,
                                 std::vector<Vec3f>* corners) const {
  const dtNavMeshQuery& query = *context.query;
  const auto start = locate(query, from, kPickHalfExtents);
  const auto end = locate(query, to, kPickHalfExtents);
  if (!start || !end) return kUnreachable;

  // trivial path (Habitat returns it before any search)
  if ((start->point - end->point).norm() < 1e-6f) {
    if (corners != nullptr) *corners = {start->point, end->point};
    return 0.0f;
  }
  // the island table answers "no path" without a search
  const int island = islandOf(start->ref);
  if (island < 0 || island != islandOf(end->ref)) return kUnreachable;

  // polygon corridor; anything but a complete path is unreachable
  int numPath = 0;
  dtStatus status = query.findPath(
      start->ref, end->ref, start->point.data(), end->point.data(), &filter,
      context.path.data(), &numPath, static_cast<int>(context.path.size()));
  if (status != DT_SUCCESS || numPath == 0) return kUnreachable;

  // string-pulled corners through the corridor
  int numCorners = 0;
  const int maxCorners = static_cast<int>(context.straight.size() / 3);
  status = query.findStraightPath(
      start->point.data(), end->point.data(), context.path.data(), numPath,
      context.straight.data(), nullptr, nullptr, &numCorners, maxCorners);
  if (status != DT_SUCCESS || numCorners == 0) return kUnreachable;
  const Vec3f last = vec(&context.straight[3 * (numCorners - 1)]);
  if ((last - end->point).norm() > kPathEndTolerance) return kUnreachable;

  float length = 0.0f;
  for (int i = 1; i < numCorners; ++i)
    length +=
        (vec(&context.straight[3 * i]) - vec(&context.straight[3 * (i - 1)]))
            .norm();
  if (corners != nullptr) {
    corners->clear();
    for (int i = 0; i < numCorners; ++i)
      corners->push_back(vec(&context.straight[3 * i]));
  }
  return length;
}

void NavMesh::Impl::disableZeroAreaPolygons() {
  // degenerate polygons crash Detour when walked into (Habitat
  // removeZeroAreaPolys); off-mesh links have no area and stay as they are
  for (int i = 0; i < mesh->getMaxTiles(); ++i) {
    const dtMeshTile* tile = static_cast<const dtNavMesh&>(*mesh).getTile(i);
    if (tile == nullptr || tile->header == nullptr) continue;
    const dtPolyRef base = mesh->getPolyRefBase(tile);
    for (int ip = 0; ip < tile->header->polyCount; ++ip) {
      if (tile->polys[ip].getType() == DT_POLYTYPE_OFFMESH_CONNECTION) continue;
      float area = 0.0f;
      forEachDetailTriangle(
          *tile, ip, [&](const Triangle& t) { area += triangleArea(t); });
      if (area < kMinPolygonArea)
        mesh->setPolyFlags(base | static_cast<dtPolyRef>(ip),
                           detail::kPolyFlagDisabled);
    }
  }
}

void NavMesh::Impl::buildIslands() {
  const dtNavMesh& nav = *mesh;
  polyIsland.assign(static_cast<size_t>(numPolys), -1);
  std::vector<float> areas;  // per island, in discovery order
  std::vector<dtPolyRef> stack;

  // flood fill over polygon links (no off-mesh links) between polygons that
  // pass the walk filter
  for (int i = 0; i < nav.getMaxTiles(); ++i) {
    const dtMeshTile* tile = nav.getTile(i);
    if (tile == nullptr || tile->header == nullptr) continue;
    const dtPolyRef base = nav.getPolyRefBase(tile);
    for (int ip = 0; ip < tile->header->polyCount; ++ip) {
      const dtPoly* poly = &tile->polys[ip];
      const dtPolyRef seed = base | static_cast<dtPolyRef>(ip);
      if (!walkable(*poly) ||
          polyIsland[static_cast<size_t>(globalIndex(seed))] >= 0)
        continue;
      const int island = static_cast<int>(areas.size());
      areas.push_back(0.0f);
      polyIsland[static_cast<size_t>(globalIndex(seed))] = island;
      stack.assign(1, seed);
      while (!stack.empty()) {
        const dtPolyRef ref = stack.back();
        stack.pop_back();
        const dtMeshTile* t = nullptr;
        const dtPoly* p = nullptr;
        nav.getTileAndPolyByRefUnsafe(ref, &t, &p);
        forEachDetailTriangle(
            *t, static_cast<int>(nav.decodePolyIdPoly(ref)),
            [&](const Triangle& tri) { areas[island] += triangleArea(tri); });
        for (unsigned k = p->firstLink; k != DT_NULL_LINK;
             k = t->links[k].next) {
          const dtPolyRef next = t->links[k].ref;
          if (next == 0) continue;
          const dtMeshTile* nt = nullptr;
          const dtPoly* np = nullptr;
          nav.getTileAndPolyByRefUnsafe(next, &nt, &np);
          int& slot = polyIsland[static_cast<size_t>(globalIndex(next))];
          if (slot >= 0 || !walkable(*np)) continue;
          slot = island;
          stack.push_back(next);
        }
      }
    }
  }

  // renumber by decreasing area (ties: discovery order) so island 0 is the
  // main floor
  std::vector<int> order(areas.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return areas[a] > areas[b]; });
  std::vector<int> rank(areas.size());
  islandAreas.resize(areas.size());
  for (size_t r = 0; r < order.size(); ++r) {
    rank[static_cast<size_t>(order[r])] = static_cast<int>(r);
    islandAreas[r] = areas[static_cast<size_t>(order[r])];
  }
  for (int& island : polyIsland)
    if (island >= 0) island = rank[static_cast<size_t>(island)];
  totalArea = std::accumulate(islandAreas.begin(), islandAreas.end(), 0.0f);

  // detail triangles grouped by island for area-weighted sampling
  std::vector<std::vector<Triangle>> byIsland(islandAreas.size());
  for (int i = 0; i < nav.getMaxTiles(); ++i) {
    const dtMeshTile* tile = nav.getTile(i);
    if (tile == nullptr || tile->header == nullptr) continue;
    for (int ip = 0; ip < tile->header->polyCount; ++ip) {
      const int island = polyIsland[static_cast<size_t>(
          tileBase[static_cast<size_t>(i)] + ip)];
      if (island < 0) continue;
      forEachDetailTriangle(*tile, ip, [&](Triangle tri) {
        // face up (+Y) so that consumers can rely on the winding
        if ((tri[1] - tri[0]).cross(tri[2] - tri[0]).y() < 0.0f)
          std::swap(tri[1], tri[2]);
        byIsland[static_cast<size_t>(island)].push_back(tri);
      });
    }
  }
  double running = 0.0;
  islandTriangleBegin.clear();
  for (const auto& group : byIsland) {
    islandTriangleBegin.push_back(triangles.size());
    for (const Triangle& tri : group) {
      triangles.push_back(tri);
      running += triangleArea(tri);
      cumulativeArea.push_back(running);
    }
  }
  islandTriangleBegin.push_back(triangles.size());
}

// ===========================================================================
// construction, save and load
// ===========================================================================

NavMesh::NavMesh(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
NavMesh::~NavMesh() = default;

std::unique_ptr<NavMesh> NavMesh::build(const TriangleMesh& mesh,
                                        const NavMeshConfig& config) {
  detail::DetourTile tile = detail::buildDetourTile(mesh, config);
  const std::string problem = tileDataProblem(tile.data.get(), tile.size);
  VLN_CHECK_IO(problem.empty(),
               "NavMesh::build(): Recast produced an unusable tile: ", problem);
  ensureDetailBoundaryEdges(tile.data.get());
  DtNavMeshPtr nav(dtAllocNavMesh());
  VLN_CHECK_IO(nav != nullptr, "NavMesh::build(): out of memory");
  // with DT_TILE_FREE_DATA the navmesh owns the data once init succeeds
  const dtStatus status =
      nav->init(tile.data.get(), tile.size, DT_TILE_FREE_DATA);
  VLN_CHECK_IO(dtStatusSucceed(status),
               "NavMesh::build(): Detour rejected the built tile (status 0x",
               std::hex, status, ")");
  static_cast<void>(tile.data.release());
  return std::unique_ptr<NavMesh>(
      new NavMesh(std::make_unique<Impl>(std::move(nav), config)));
}

void NavMesh::save(const std::filesystem::path& file) const {
  const dtNavMesh& nav = *impl_->mesh;
  std::vector<const dtMeshTile*> tiles;
  for (int i = 0; i < nav.getMaxTiles(); ++i) {
    const dtMeshTile* tile = nav.getTile(i);
    if (tile != nullptr && tile->header != nullptr && tile->dataSize > 0)
      tiles.push_back(tile);
  }

  // set header, then (tileRef, dataSize, data) per tile, native byte order
  // like the Recast demo and Habitat
  std::string bytes;
  appendRaw(bytes, kNavMeshSetMagic);
  appendRaw(bytes, kNavMeshSetVersion);
  appendRaw(bytes, static_cast<int32_t>(tiles.size()));
  appendRaw(bytes, *nav.getParams());
  for (const dtMeshTile* tile : tiles) {
    appendRaw(bytes, nav.getTileRef(tile));
    appendRaw(bytes, static_cast<int32_t>(tile->dataSize));
    bytes.append(reinterpret_cast<const char*>(tile->data),
                 static_cast<size_t>(tile->dataSize));
  }
  common::writeFileAtomic(file, bytes);
}

std::unique_ptr<NavMesh> NavMesh::load(const std::filesystem::path& file) {
  const std::string bytes = common::readFile(file);
  const std::string where = strCat("NavMesh::load(): ", file.string(), ": ");

  // set header
  VLN_CHECK_IO(bytes.size() >= kSetHeaderBytes, where,
               "truncated: ", bytes.size(), " bytes, a navmesh header needs ",
               kSetHeaderBytes);
  const auto magic = readRaw<int32_t>(bytes, 0);
  VLN_CHECK_IO(magic == kNavMeshSetMagic, where, "not a navmesh (magic 0x",
               std::hex, magic, ", expected 0x", kNavMeshSetMagic, " 'MSET')");
  const auto version = readRaw<int32_t>(bytes, 4);
  VLN_CHECK_IO(version == kNavMeshSetVersion, where, "unsupported version ",
               version, ", expected ", kNavMeshSetVersion);
  const auto numTiles = readRaw<int32_t>(bytes, 8);
  const auto params = readRaw<dtNavMeshParams>(bytes, 12);
  // 32-bit refs leave at most 22 bits for tile and polygon indices
  VLN_CHECK_IO(numTiles >= 1 && numTiles <= params.maxTiles &&
                   params.maxTiles <= (1 << 22) && params.maxPolys >= 1 &&
                   params.maxPolys <= (1 << 22),
               where, "corrupt header: ", numTiles, " tiles, maxTiles ",
               params.maxTiles, ", maxPolys ", params.maxPolys);
  VLN_CHECK_IO(std::isfinite(params.orig[0]) && std::isfinite(params.orig[1]) &&
                   std::isfinite(params.orig[2]) &&
                   std::isfinite(params.tileWidth) &&
                   std::isfinite(params.tileHeight),
               where, "corrupt header: non-finite tile grid");
  DtNavMeshPtr nav(dtAllocNavMesh());
  VLN_CHECK_IO(nav != nullptr, where, "out of memory");
  VLN_CHECK_IO(dtStatusSucceed(nav->init(&params)), where,
               "corrupt header: Detour rejects maxTiles ", params.maxTiles,
               " with maxPolys ", params.maxPolys);

  // tiles; like Habitat, a zero ref or size ends the list early
  NavMeshConfig config;
  bool configFromTile = false;
  size_t offset = kSetHeaderBytes;
  int loaded = 0;
  for (int i = 0; i < numTiles; ++i) {
    VLN_CHECK_IO(bytes.size() - offset >= kTileHeaderBytes, where,
                 "truncated in the header of tile ", i, " of ", numTiles);
    const auto tileRef = readRaw<dtTileRef>(bytes, offset);
    const auto dataSize = readRaw<int32_t>(bytes, offset + sizeof(dtTileRef));
    offset += kTileHeaderBytes;
    if (tileRef == 0 || dataSize == 0) break;
    VLN_CHECK_IO(dataSize > 0, where, "corrupt tile ", i, ": size ", dataSize);
    VLN_CHECK_IO(bytes.size() - offset >= static_cast<size_t>(dataSize), where,
                 "truncated: tile ", i, " needs ", dataSize, " bytes, ",
                 bytes.size() - offset, " left");
    detail::DetourData data(static_cast<unsigned char*>(
        dtAlloc(static_cast<size_t>(dataSize), DT_ALLOC_PERM)));
    VLN_CHECK_IO(data != nullptr, where, "out of memory");
    std::memcpy(data.get(), bytes.data() + offset,
                static_cast<size_t>(dataSize));
    offset += static_cast<size_t>(dataSize);
    const std::string problem = tileDataProblem(data.get(), dataSize);
    VLN_CHECK_IO(problem.empty(), where, "corrupt tile ", i, ": ", problem);
    ensureDetailBoundaryEdges(data.get());
    // polygon refs reserve bits for maxPolys polygons per tile only
    const auto* header = reinterpret_cast<const dtMeshHeader*>(data.get());
    VLN_CHECK_IO(header->polyCount <= params.maxPolys, where, "corrupt tile ",
                 i, ": ", header->polyCount, " polygons, the header allows ",
                 params.maxPolys);
    const dtStatus status =
        nav->addTile(data.get(), dataSize, DT_TILE_FREE_DATA, tileRef, nullptr);
    VLN_CHECK_IO(dtStatusSucceed(status), where, "corrupt tile ", i,
                 ": Detour rejects it (status 0x", std::hex, status, ")");
    // the file records the agent it was built for; the rest stay defaults
    if (!configFromTile) {
      config.agent_height = header->walkableHeight;
      config.agent_radius = header->walkableRadius;
      config.agent_max_climb = header->walkableClimb;
      configFromTile = true;
    }
    static_cast<void>(data.release());
    ++loaded;
  }
  VLN_CHECK_IO(loaded > 0, where, "contains no tiles");
  return std::unique_ptr<NavMesh>(
      new NavMesh(std::make_unique<Impl>(std::move(nav), config)));
}

// ===========================================================================
// queries
// ===========================================================================

std::optional<Vec3f> NavMesh::snapPoint(const Vec3f& p,
                                        const Vec3f& halfExtents) const {
  const auto lease = impl_->acquire();
  const auto located = impl_->locate(*lease->query, p, halfExtents.data());
  if (!located) return std::nullopt;
  return located->point;
}

bool NavMesh::isNavigable(const Vec3f& p, float maxYDelta) const {
  const auto lease = impl_->acquire();
  return impl_->locateNavigable(*lease->query, p, maxYDelta).has_value();
}

int NavMesh::islandIndex(const Vec3f& p) const {
  const auto lease = impl_->acquire();
  const auto located =
      impl_->locateNavigable(*lease->query, p, /*maxYDelta=*/0.5f);
  return located ? impl_->islandOf(located->ref) : -1;
}

int NavMesh::islandCount() const {
  return static_cast<int>(impl_->islandAreas.size());
}

float NavMesh::islandArea(int island) const {
  VLN_CHECK_ARG(island >= 0 && island < islandCount(),
                "NavMesh::islandArea(): island must be in [0, ", islandCount(),
                "), got ", island);
  return impl_->islandAreas[static_cast<size_t>(island)];
}

float NavMesh::navigableArea() const { return impl_->totalArea; }

int NavMesh::polygonCount() const { return impl_->numPolys; }

float NavMesh::geodesicDistance(const Vec3f& from, const Vec3f& to) const {
  auto lease = impl_->acquire();
  return impl_->findCorners(*lease, from, to, nullptr);
}

std::vector<Vec3f> NavMesh::shortestPath(const Vec3f& from,
                                         const Vec3f& to) const {
  auto lease = impl_->acquire();
  std::vector<Vec3f> corners;
  if (impl_->findCorners(*lease, from, to, &corners) == kUnreachable) return {};
  return corners;
}

Vec3f NavMesh::moveAlongSurface(const Vec3f& from, const Vec3f& to) const {
  // Habitat tryStep(allowSliding=true)
  const auto lease = impl_->acquire();
  const dtNavMeshQuery& query = *lease->query;
  const auto start = impl_->locate(query, from, kPickHalfExtents);
  const auto end = impl_->locate(query, to, kPickHalfExtents);
  if (!start || !end) return from;
  const int island = impl_->islandOf(start->ref);
  if (island < 0 || island != impl_->islandOf(end->ref)) return from;

  Vec3f result = from;
  std::array<dtPolyRef, kMaxMovePolys> visited{};
  int numVisited = 0;
  query.moveAlongSurface(start->ref, start->point.data(), to.data(),
                         &impl_->filter, result.data(), visited.data(),
                         &numVisited, kMaxMovePolys);
  if (numVisited == 0) return from;
  // moveAlongSurface keeps the start height; put the point on the surface
  const dtPolyRef last = visited[static_cast<size_t>(numVisited - 1)];
  query.getPolyHeight(last, result.data(), &result.y());

  // Recast has infinitely thin walls: a point on the seam between two
  // islands may snap to the other one; nudge it into the polygon the move
  // ended in (Habitat does the same)
  const auto landed = impl_->locate(query, result, kPickHalfExtents);
  if (!landed || impl_->islandOf(landed->ref) != island) {
    const dtMeshTile* tile = nullptr;
    const dtPoly* poly = nullptr;
    impl_->mesh->getTileAndPolyByRefUnsafe(last, &tile, &poly);
    Vec3f center = Vec3f::Zero();
    for (int k = 0; k < poly->vertCount; ++k)
      center += vec(&tile->verts[poly->verts[k] * 3]);
    center /= static_cast<float>(poly->vertCount);
    result += kThinWallNudge * (center - result).normalized();
  }
  return result;
}

Vec3f NavMesh::moveNoSliding(const Vec3f& from, const Vec3f& to) const {
  const Vec3f reached = moveAlongSurface(from, to);
  return horizontalDistance(reached, to) > kNoSlideTolerance ? from : reached;
}

float NavMesh::distanceToObstacle(const Vec3f& p, float maxRadius) const {
  const auto lease = impl_->acquire();
  const dtNavMeshQuery& query = *lease->query;
  const auto located = impl_->locate(query, p, kPickHalfExtents);
  if (!located) return 0.0f;
  float distance = 0.0f;
  Vec3f hitPoint;
  Vec3f hitNormal;
  const dtStatus status = query.findDistanceToWall(
      located->ref, located->point.data(), maxRadius, &impl_->filter, &distance,
      hitPoint.data(), hitNormal.data());
  return dtStatusSucceed(status) ? distance : 0.0f;
}

Vec3f NavMesh::randomPoint(std::mt19937_64& rng, int island) const {
  VLN_CHECK_ARG(island >= -1 && island < islandCount(),
                "NavMesh::randomPoint(): island must be -1 or in [0, ",
                islandCount(), "), got ", island);
  VLN_CHECK_IO(!impl_->triangles.empty(),
               "NavMesh::randomPoint(): the navmesh has no navigable area");
  // the triangle range of the island (or all) and its area interval
  const auto& begins = impl_->islandTriangleBegin;
  const size_t first = island < 0 ? 0 : begins[static_cast<size_t>(island)];
  const size_t last = island < 0 ? impl_->triangles.size()
                                 : begins[static_cast<size_t>(island) + 1];
  VLN_ASSERT(first < last);
  const auto& cumulative = impl_->cumulativeArea;
  const double low = first == 0 ? 0.0 : cumulative[first - 1];
  const double high = cumulative[last - 1];

  // triangle by area, then a uniform point in it
  const double target = low + common::uniform01(rng) * (high - low);
  const auto it =
      std::upper_bound(cumulative.begin() + static_cast<long>(first),
                       cumulative.begin() + static_cast<long>(last), target);
  const size_t index =
      std::min(static_cast<size_t>(it - cumulative.begin()), last - 1);
  const Triangle& t = impl_->triangles[index];
  const float s = static_cast<float>(std::sqrt(common::uniform01(rng)));
  const float r = static_cast<float>(common::uniform01(rng));
  return (1.0f - s) * t[0] + s * (1.0f - r) * t[1] + s * r * t[2];
}

std::vector<std::array<Vec3f, 3>> NavMesh::triangles() const {
  return impl_->triangles;
}

const NavMeshConfig& NavMesh::config() const { return impl_->config; }

}  // namespace vln::sim
