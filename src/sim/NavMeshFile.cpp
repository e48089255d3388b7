#include "sim/NavMeshFile.h"

#include <DetourAlloc.h>
#include <DetourCommon.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "common/Check.h"
#include "sim/NavMeshBuild.h"

namespace vln::sim::detail {

namespace {

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

}  // namespace

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

std::string encodeNavMeshSet(const dtNavMesh& nav) {
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
  return bytes;
}

DecodedNavMesh decodeNavMeshSet(const std::string& bytes,
                                const std::string& where) {
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
  return {std::move(nav), config};
}

}  // namespace vln::sim::detail
