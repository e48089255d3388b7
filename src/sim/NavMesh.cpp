#include "sim/NavMesh.h"

#include <DetourCommon.h>
#include <DetourNavMesh.h>
#include <DetourNavMeshQuery.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>

#include "common/Check.h"
#include "common/FileIo.h"
#include "common/Random.h"
#include "sim/GeometryCheck.h"
#include "sim/NavMeshBuild.h"
#include "sim/NavMeshFile.h"

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

using detail::DtNavMeshPtr;
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
  // the union of the tiles' bounds, and it grown by kPoseMargin: where
  // query points are accepted
  Eigen::AlignedBox3f bounds;
  Eigen::AlignedBox3f accepted;

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
    bounds.extend(vec(tile->header->bmin));
    bounds.extend(vec(tile->header->bmax));
  }
  accepted = poseBounds(bounds);
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
  const std::string problem =
      detail::tileDataProblem(tile.data.get(), tile.size);
  VLN_CHECK_IO(problem.empty(),
               "NavMesh::build(): Recast produced an unusable tile: ", problem);
  detail::ensureDetailBoundaryEdges(tile.data.get());
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
  common::writeFileAtomic(file, detail::encodeNavMeshSet(*impl_->mesh));
}

std::unique_ptr<NavMesh> NavMesh::load(const std::filesystem::path& file) {
  const std::string bytes = common::readFile(file);
  const std::string where = strCat("NavMesh::load(): ", file.string(), ": ");
  detail::DecodedNavMesh decoded = detail::decodeNavMeshSet(bytes, where);
  return std::unique_ptr<NavMesh>(new NavMesh(
      std::make_unique<Impl>(std::move(decoded.nav), decoded.config)));
}

// ===========================================================================
// queries
// ===========================================================================

std::optional<Vec3f> NavMesh::snapPoint(const Vec3f& p,
                                        const Vec3f& halfExtents) const {
  checkPosition("NavMesh::snapPoint()", "point", p, impl_->accepted);
  // Detour visits every tile the search box touches
  VLN_CHECK_ARG(
      halfExtents.allFinite() && halfExtents.minCoeff() >= 0.0f &&
          (halfExtents.array() <= impl_->accepted.sizes().array()).all(),
      "NavMesh::snapPoint(): halfExtents must be finite, "
      "non-negative and at most the accepted box (",
      impl_->accepted.sizes().transpose(), "), got (", halfExtents.transpose(),
      ")");
  const auto lease = impl_->acquire();
  const auto located = impl_->locate(*lease->query, p, halfExtents.data());
  if (!located) return std::nullopt;
  return located->point;
}

bool NavMesh::isNavigable(const Vec3f& p, float maxYDelta) const {
  checkPosition("NavMesh::isNavigable()", "point", p, impl_->accepted);
  const auto lease = impl_->acquire();
  return impl_->locateNavigable(*lease->query, p, maxYDelta).has_value();
}

int NavMesh::islandIndex(const Vec3f& p) const {
  checkPosition("NavMesh::islandIndex()", "point", p, impl_->accepted);
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
  checkPosition("NavMesh::geodesicDistance()", "from", from, impl_->accepted);
  checkPosition("NavMesh::geodesicDistance()", "to", to, impl_->accepted);
  auto lease = impl_->acquire();
  return impl_->findCorners(*lease, from, to, nullptr);
}

std::vector<Vec3f> NavMesh::shortestPath(const Vec3f& from,
                                         const Vec3f& to) const {
  checkPosition("NavMesh::shortestPath()", "from", from, impl_->accepted);
  checkPosition("NavMesh::shortestPath()", "to", to, impl_->accepted);
  auto lease = impl_->acquire();
  std::vector<Vec3f> corners;
  if (impl_->findCorners(*lease, from, to, &corners) == kUnreachable) return {};
  return corners;
}

Vec3f NavMesh::moveAlongSurface(const Vec3f& from, const Vec3f& to) const {
  checkPosition("NavMesh::moveAlongSurface()", "from", from, impl_->accepted);
  checkPosition("NavMesh::moveAlongSurface()", "to", to, impl_->accepted);
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
  checkPosition("NavMesh::distanceToObstacle()", "point", p, impl_->accepted);
  VLN_CHECK_ARG(std::isfinite(maxRadius) && maxRadius >= 0.0f,
                "NavMesh::distanceToObstacle(): maxRadius must be finite and "
                "non-negative, got ",
                maxRadius);
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

const Eigen::AlignedBox3f& NavMesh::bounds() const { return impl_->bounds; }

const Eigen::AlignedBox3f& NavMesh::queryBounds() const {
  return impl_->accepted;
}

}  // namespace vln::sim
