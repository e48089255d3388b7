#include "sim/NavMeshBuild.h"

#include <DetourAlloc.h>
#include <DetourNavMesh.h>
#include <DetourNavMeshBuilder.h>
#include <Recast.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "common/Check.h"
#include "common/Config.h"
#include "sim/GeometryCheck.h"

namespace vln::sim::detail {

void DetourDataDeleter::operator()(unsigned char* data) const { dtFree(data); }

namespace {

// A grid larger than this many cells is almost surely a unit mistake (a mesh
// in millimetres, a stray far vertex); Recast would try to allocate several
// GB for it. 1e8 cells is 500 m x 500 m at the default 5 cm cells.
constexpr double kMaxGridCells = 1e8;
// Recast's polygon mesh stores vertex coordinates in cells as unsigned
// short, so one tile is at most this many cells wide and deep.
constexpr double kMaxGridSide = 65535;

// Recast reports failures only through its context log; collect the errors
// and warnings so that exceptions can quote them.
class RecastLog : public rcContext {
 public:
  RecastLog() : rcContext(/*state=*/true) {}
  const std::string& messages() const { return messages_; }

 protected:
  void doLog(const rcLogCategory category, const char* msg,
             const int len) override {
    if (category == RC_LOG_PROGRESS) return;
    if (!messages_.empty()) messages_ += "; ";
    messages_.append(msg, static_cast<size_t>(len));
  }

 private:
  std::string messages_;
};

// unique_ptr deleters for every heap structure of the pipeline, so that an
// exception at any stage frees what was built so far.
struct HeightfieldDeleter {
  void operator()(rcHeightfield* p) const { rcFreeHeightField(p); }
};
struct CompactHeightfieldDeleter {
  void operator()(rcCompactHeightfield* p) const {
    rcFreeCompactHeightfield(p);
  }
};
struct ContourSetDeleter {
  void operator()(rcContourSet* p) const { rcFreeContourSet(p); }
};
struct PolyMeshDeleter {
  void operator()(rcPolyMesh* p) const { rcFreePolyMesh(p); }
};
struct PolyMeshDetailDeleter {
  void operator()(rcPolyMeshDetail* p) const { rcFreePolyMeshDetail(p); }
};

template <class T, class Deleter>
std::unique_ptr<T, Deleter> allocated(T* p, const char* what) {
  // Recast returns nullptr only when malloc fails
  if (p == nullptr)
    throw std::runtime_error(
        strCat("NavMesh::build(): out of memory allocating the ", what));
  return std::unique_ptr<T, Deleter>(p);
}

void checkStage(bool ok, const char* stage, const RecastLog& log) {
  VLN_CHECK_IO(ok, "NavMesh::build(): Recast stage ", stage, " failed",
               log.messages().empty() ? "" : ": ", log.messages());
}

[[noreturn]] void throwNothingWalkable(const TriangleMesh& mesh,
                                       const NavMeshConfig& config,
                                       std::string_view where) {
  const Eigen::AlignedBox3f box = mesh.bounds();
  throw std::invalid_argument(strCat(
      "NavMesh::build(): the mesh has no walkable surface (", where, "; ",
      mesh.triangleCount(), " triangles, bounds [", box.min().transpose(),
      "] to [", box.max().transpose(), "], agent_height ", config.agent_height,
      " m, agent_radius ", config.agent_radius, " m, agent_max_slope ",
      config.agent_max_slope, " deg); is the mesh Y-up and in metres?"));
}

// Habitat-Sim's NavMeshSettings -> rcConfig conversion (PathFinder::build),
// kept literally so that both produce the same navmesh from the same mesh.
rcConfig recastConfig(const NavMeshConfig& c, const Eigen::AlignedBox3f& box) {
  rcConfig cfg{};
  cfg.cs = c.cell_size;
  cfg.ch = c.cell_height;
  cfg.walkableSlopeAngle = c.agent_max_slope;
  cfg.walkableHeight = static_cast<int>(std::ceil(c.agent_height / cfg.ch));
  cfg.walkableClimb = static_cast<int>(std::floor(c.agent_max_climb / cfg.ch));
  cfg.walkableRadius = static_cast<int>(std::ceil(c.agent_radius / cfg.cs));
  cfg.maxEdgeLen = static_cast<int>(c.edge_max_len / c.cell_size);
  cfg.maxSimplificationError = c.edge_max_error;
  // region sizes are given as the side of a square of cells
  cfg.minRegionArea = static_cast<int>(rcSqr(c.region_min_size));
  cfg.mergeRegionArea = static_cast<int>(rcSqr(c.region_merge_size));
  cfg.maxVertsPerPoly = c.verts_per_poly;
  cfg.detailSampleDist =
      c.detail_sample_dist < 0.9f ? 0.0f : c.cell_size * c.detail_sample_dist;
  cfg.detailSampleMaxError = c.cell_height * c.detail_sample_max_error;
  for (int i = 0; i < 3; ++i) {
    cfg.bmin[i] = box.min()[i];
    cfg.bmax[i] = box.max()[i];
  }
  rcCalcGridSize(cfg.bmin, cfg.bmax, cfg.cs, &cfg.width, &cfg.height);
  return cfg;
}

}  // namespace

DetourTile buildDetourTile(const TriangleMesh& mesh,
                           const NavMeshConfig& config) {
  // inputs: bounds-checked config, well-formed mesh
  NavMeshConfig checked = config;
  common::checkConfig([&](common::ConfigVisitor& v) { checked.visit(v); },
                      "NavMesh::build() navmesh config");
  mesh.validate("NavMesh::build()");
  VLN_CHECK_ARG(mesh.positions.size() <= static_cast<size_t>(INT32_MAX) &&
                    mesh.triangleCount() <= static_cast<size_t>(INT32_MAX),
                "NavMesh::build(): mesh too large for Recast, got ",
                mesh.positions.size(), " vertices and ", mesh.triangleCount(),
                " triangles");

  checkSceneGeometry(mesh, "NavMesh::build()");

  // the grid, sized in double first: rcCalcGridSize's float-to-int
  // conversion overflows on huge extents
  const Eigen::AlignedBox3f box = mesh.bounds();
  const double columns =
      std::floor(static_cast<double>(box.sizes().x()) / config.cell_size + 0.5);
  const double rows =
      std::floor(static_cast<double>(box.sizes().z()) / config.cell_size + 0.5);
  VLN_CHECK_ARG(
      columns * rows <= kMaxGridCells, "NavMesh::build(): the mesh spans ",
      columns, " x ", rows, " cells of ", config.cell_size, " m (bounds [",
      box.min().transpose(), "] to [", box.max().transpose(), "]); more than ",
      kMaxGridCells, " cells, check the mesh scale");
  VLN_CHECK_ARG(columns <= kMaxGridSide && rows <= kMaxGridSide,
                "NavMesh::build(): the mesh spans ", columns, " x ", rows,
                " cells of ", config.cell_size, " m (bounds [",
                box.min().transpose(), "] to [", box.max().transpose(),
                "]); one Recast tile holds at most ", kMaxGridSide,
                " cells along x and z");
  const rcConfig cfg = recastConfig(config, box);
  // a grid 0 cells wide or deep makes rcRasterizeTriangles write outside
  // the heightfield (a SIGSEGV on a flat Z-up plane read Y-up)
  if (cfg.width < 1 || cfg.height < 1)
    throwNothingWalkable(
        mesh, config,
        strCat("the mesh is flat along world ", cfg.width < 1 ? "x" : "z",
               ", less than one cell (", config.cell_size,
               " m) across: a floor authored Z-up and read Y-up looks like "
               "this"));

  RecastLog log;
  const auto* verts = mesh.positions.front().data();
  const int numVerts = static_cast<int>(mesh.positions.size());
  const int numTris = static_cast<int>(mesh.triangleCount());
  const std::vector<int> tris(mesh.indices.begin(), mesh.indices.end());

  // rasterise the walkable-marked triangles into a voxel heightfield
  auto solid = allocated<rcHeightfield, HeightfieldDeleter>(
      rcAllocHeightfield(), "heightfield");
  checkStage(rcCreateHeightfield(&log, *solid, cfg.width, cfg.height, cfg.bmin,
                                 cfg.bmax, cfg.cs, cfg.ch),
             "rcCreateHeightfield", log);
  std::vector<unsigned char> areas(static_cast<size_t>(numTris), 0);
  rcMarkWalkableTriangles(&log, cfg.walkableSlopeAngle, verts, numVerts,
                          tris.data(), numTris, areas.data());
  checkStage(
      rcRasterizeTriangles(&log, verts, numVerts, tris.data(), areas.data(),
                           numTris, *solid, cfg.walkableClimb),
      "rcRasterizeTriangles", log);

  // Habitat's optional filters remove overhang artefacts of conservative
  // rasterisation, ledges and spans without head room
  if (config.filter_low_hanging_obstacles)
    rcFilterLowHangingWalkableObstacles(&log, cfg.walkableClimb, *solid);
  if (config.filter_ledge_spans)
    rcFilterLedgeSpans(&log, cfg.walkableHeight, cfg.walkableClimb, *solid);
  if (config.filter_walkable_low_height_spans)
    rcFilterWalkableLowHeightSpans(&log, cfg.walkableHeight, *solid);

  // compact heightfield, eroded by the agent radius; the solid heightfield
  // is the largest structure and is no longer needed afterwards
  auto chf = allocated<rcCompactHeightfield, CompactHeightfieldDeleter>(
      rcAllocCompactHeightfield(), "compact heightfield");
  checkStage(rcBuildCompactHeightfield(&log, cfg.walkableHeight,
                                       cfg.walkableClimb, *solid, *chf),
             "rcBuildCompactHeightfield", log);
  solid.reset();
  checkStage(rcErodeWalkableArea(&log, cfg.walkableRadius, *chf),
             "rcErodeWalkableArea", log);
  int walkableSpans = 0;
  for (int i = 0; i < chf->spanCount; ++i)
    walkableSpans += chf->areas[i] != RC_NULL_AREA ? 1 : 0;
  if (walkableSpans == 0)
    throwNothingWalkable(mesh, config, "no walkable voxel after erosion");

  // watershed partition into simple regions (Habitat's choice)
  checkStage(rcBuildDistanceField(&log, *chf), "rcBuildDistanceField", log);
  checkStage(rcBuildRegions(&log, *chf, /*borderSize=*/0, cfg.minRegionArea,
                            cfg.mergeRegionArea),
             "rcBuildRegions", log);

  // region contours, then convex polygons
  auto cset = allocated<rcContourSet, ContourSetDeleter>(rcAllocContourSet(),
                                                         "contour set");
  checkStage(rcBuildContours(&log, *chf, cfg.maxSimplificationError,
                             cfg.maxEdgeLen, *cset),
             "rcBuildContours", log);
  auto pmesh =
      allocated<rcPolyMesh, PolyMeshDeleter>(rcAllocPolyMesh(), "polygon mesh");
  checkStage(rcBuildPolyMesh(&log, *cset, cfg.maxVertsPerPoly, *pmesh),
             "rcBuildPolyMesh", log);
  if (pmesh->npolys == 0)
    throwNothingWalkable(mesh, config,
                         "every walkable region is smaller than "
                         "region_min_size");

  // height detail so that queries return points on the true surface
  auto dmesh = allocated<rcPolyMeshDetail, PolyMeshDetailDeleter>(
      rcAllocPolyMeshDetail(), "detail mesh");
  checkStage(rcBuildPolyMeshDetail(&log, *pmesh, *chf, cfg.detailSampleDist,
                                   cfg.detailSampleMaxError, *dmesh),
             "rcBuildPolyMeshDetail", log);

  // every polygon is walkable ground (no doors, no off-mesh links)
  for (int i = 0; i < pmesh->npolys; ++i) {
    if (pmesh->areas[i] == RC_WALKABLE_AREA) pmesh->areas[i] = kPolyAreaGround;
    if (pmesh->areas[i] == kPolyAreaGround) pmesh->flags[i] = kPolyFlagWalk;
  }

  // pack as one Detour tile
  VLN_CHECK_ARG(cfg.maxVertsPerPoly <= DT_VERTS_PER_POLYGON,
                "NavMesh::build(): verts_per_poly must be at most ",
                DT_VERTS_PER_POLYGON, ", got ", cfg.maxVertsPerPoly);
  dtNavMeshCreateParams params{};
  params.verts = pmesh->verts;
  params.vertCount = pmesh->nverts;
  params.polys = pmesh->polys;
  params.polyAreas = pmesh->areas;
  params.polyFlags = pmesh->flags;
  params.polyCount = pmesh->npolys;
  params.nvp = pmesh->nvp;
  params.detailMeshes = dmesh->meshes;
  params.detailVerts = dmesh->verts;
  params.detailVertsCount = dmesh->nverts;
  params.detailTris = dmesh->tris;
  params.detailTriCount = dmesh->ntris;
  params.walkableHeight = config.agent_height;
  params.walkableRadius = config.agent_radius;
  params.walkableClimb = config.agent_max_climb;
  rcVcopy(params.bmin, pmesh->bmin);
  rcVcopy(params.bmax, pmesh->bmax);
  params.cs = cfg.cs;
  params.ch = cfg.ch;
  params.buildBvTree = true;

  unsigned char* data = nullptr;
  int size = 0;
  VLN_CHECK_IO(dtCreateNavMeshData(&params, &data, &size),
               "NavMesh::build(): dtCreateNavMeshData failed for ",
               pmesh->npolys, " polygons and ", pmesh->nverts,
               " vertices (Detour allows at most 65535 vertices per tile)");
  return DetourTile{DetourData(data), size};
}

}  // namespace vln::sim::detail
