#include "sim/RasterRenderer.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <vector>

#include "common/Check.h"
#include "sim/Mesh.h"
#include "sim/Shading.h"

namespace vln::sim {

namespace {

using enum Renderer::Output;

// Rasterising loops are compiled twice: for AVX2, where GCC vectorises them
// eight pixels at a time, and for the baseline. The loops use no fused
// operations (the build's ISO mode keeps -ffp-contract=off), so both clones
// compute the same bits.
#define VLN_RASTER_CLONES __attribute__((target_clones("avx2", "default")))

// Camera-frame depth (metres in front of the eye) below which a vertex
// counts as "not in front" when bounding a triangle's pixels. The part of a
// triangle closer than this is left out of the bound only; it could cover a
// pixel only within kNearBound * tan(hfov / 2) of the eye.
constexpr float kNearBound = 1e-5f;

// Relative slack on a triangle's nearest inverse depth (ViewTriangle) for
// the rounding of the inverse depths drawn from its edge functions.
constexpr float kNearestSlack = 1e-4f;

// Side of the square pixel tiles whose farthest hit render() keeps, to skip
// triangles (and runs of a triangle's rows) that lie wholly behind what is
// already drawn. Equal to the eight columns a row is drawn in at once, so a
// block of a row lies in one tile.
constexpr int kTile = 8;

// The smallest inverse depth of the pixels [x0, x0 + columns) x [y0, y0 +
// rows) of a row-major buffer with rows `stride` apart; whole tiles take a loop
// of fixed length that compiles to a few vector minimums.
VLN_RASTER_CLONES float farthestInTile(const float* inverseDepth, size_t stride,
                                       int x0, int y0, int columns, int rows) {
  const float* first =
      inverseDepth + static_cast<size_t>(y0) * stride + static_cast<size_t>(x0);
  if (columns == kTile && rows == kTile) {
    float lanes[kTile];
    for (int k = 0; k < kTile; ++k) lanes[k] = first[k];
    for (int row = 1; row < kTile; ++row) {
      const float* line = first + static_cast<size_t>(row) * stride;
      for (int k = 0; k < kTile; ++k) lanes[k] = std::min(lanes[k], line[k]);
    }
    float farthest = lanes[0];
    for (int k = 1; k < kTile; ++k) farthest = std::min(farthest, lanes[k]);
    return farthest;
  }
  float farthest = std::numeric_limits<float>::infinity();
  for (int row = 0; row < rows; ++row) {
    const float* line = first + static_cast<size_t>(row) * stride;
    for (int k = 0; k < columns; ++k) farthest = std::min(farthest, line[k]);
  }
  return farthest;
}

// The edge functions of one triangle seen from the eye, as functions of a
// pixel's camera-frame ray d = (X, Y, -1) (pixelDirection()):
// edge[i] = a[i] X + b[i] Y + c[i] is (p_j x p_k) . d for the edge (p_j, p_k)
// opposite corner i (camera-frame corners p), signed so that all three are
// >= 0 exactly where the ray passes through the triangle in front of the
// eye. Their sum is det / t, where det = |p0 . (p1 x p2)| and t the ray
// parameter of the hit, which is its z-depth; so the barycentrics of the hit
// are edge[i] / sum (corner 1's is Embree's u, corner 2's its v), and
// inverse depth 1 / t = sum / det is linear in X and Y: its coefficients are
// the last entries.
struct EdgeFunctions {
  float a[4];
  float b[4];
  float c[4];
};

// Where a triangle may cover pixels: its rows, and the map from a ray slope
// X to a fractional column, column = X * columnScale + columnOffset.
struct PixelBounds {
  int firstRow, lastRow, firstColumn, lastColumn;
  float columnScale, columnOffset;
};

// The tiles' farthest hits as rasterizeTriangle() reads them: lower bounds
// on the inverse depth of every pixel in each tile (row-major, `tilesX` per
// row), and the triangle's own upper bound.
struct Occlusion {
  const float* tileFarthest;
  size_t tilesX;
  float nearest;
};

// Eight lanes of GCC's vector extensions: the AVX2 clones compute with one
// register, the baseline with two SSE registers, lane for lane the same
// IEEE operations.
using Floats8 = float __attribute__((vector_size(32)));
using Ints8 = int32_t __attribute__((vector_size(32)));
constexpr Ints8 kLanes = {0, 1, 2, 3, 4, 5, 6, 7};
// A value in every lane is written `value - Floats8{}` (x - 0 is x exactly,
// -0 included) or `value + Ints8{}`, inside the cloned function itself: a
// helper would be lowered for the baseline before inlining and then build
// the vector lane by lane in the AVX2 clone too.

// Draws one triangle into the visibility buffer: each pixel centre inside it
// (all three edge functions >= 0) whose stored hit is farther takes it.
// `inverseDepth` holds 1 / z-depth (0 where nothing was hit yet), so nearer
// is larger. Per row, the columns are first narrowed to where each edge
// function can be >= 0 (with a column of slack for rounding; the edge tests
// decide), which skips most of the bounding box of a thin or slanted
// triangle. Rows are `stride` apart, a multiple of eight, and `columnX` has
// `stride` entries.
VLN_RASTER_CLONES void rasterizeTriangle(
    const float* columnX, const float* rowY, const EdgeFunctions& f,
    const PixelBounds& bounds, const Occlusion& occlusion, int32_t triangle,
    size_t stride, float* inverseDepth, int32_t* visible) {
  // locals, so the stores below cannot alias them and the span loop
  // vectorises
  const float a0 = f.a[0], a1 = f.a[1], a2 = f.a[2], as = f.a[3];
  const float b0 = f.b[0], b1 = f.b[1], b2 = f.b[2], bs = f.b[3];
  const float c0 = f.c[0], c1 = f.c[1], c2 = f.c[2], cs = f.c[3];
  const Floats8 a0v = (a0 - Floats8{}), a1v = (a1 - Floats8{}),
                a2v = (a2 - Floats8{}), asv = (as - Floats8{});
  const float firstColumnF = static_cast<float>(bounds.firstColumn);
  const float lastColumnF = static_cast<float>(bounds.lastColumn);
  // edge i is >= 0 on one side of the column where a_i X + r_i = 0, i.e.
  // X = -r_i / a_i: column = r_i * scale_i + columnOffset
  auto crossingScale = [&](float a) {
    return a == 0.0f ? 0.0f : -bounds.columnScale / a;
  };
  const float k0 = crossingScale(a0), k1 = crossingScale(a1),
              k2 = crossingScale(a2);
  for (int row = bounds.firstRow; row <= bounds.lastRow; ++row) {
    const float y = rowY[row];
    const float r0 = b0 * y + c0;
    const float r1 = b1 * y + c1;
    const float r2 = b2 * y + c2;
    const float rs = bs * y + cs;
    // narrow [low, high] to where each edge function can be >= 0
    float low = firstColumnF;
    float high = lastColumnF;
    bool empty = false;
    auto narrow = [&](float a, float r, float k) {
      if (a == 0.0f) {
        empty = empty || r < 0.0f;
        return;
      }
      const float column = r * k + bounds.columnOffset;
      if (a > 0.0f) {
        low = std::max(low, column - 1.0f);
      } else {
        high = std::min(high, column + 1.0f);
      }
    };
    narrow(a0, r0, k0);
    narrow(a1, r1, k1);
    narrow(a2, r2, k2);
    // NaN bounds (from an infinite crossing) compare false: the box stays
    if (empty || !(low <= high)) continue;
    // both are within [0, lastColumn]: truncation floors; one more column
    // stands in for the ceiling
    const int first = static_cast<int>(low);
    const int last = std::min(static_cast<int>(high) + 1, bounds.lastColumn);
    // whole blocks of eight columns (rows are padded to them), the columns
    // outside [first, last] masked
    float* depthRow = inverseDepth + static_cast<size_t>(row) * stride;
    int32_t* visibleRow = visible + static_cast<size_t>(row) * stride;
    const Floats8 e0Row = (r0 - Floats8{}), e1Row = (r1 - Floats8{}),
                  e2Row = (r2 - Floats8{}), sRow = (rs - Floats8{});
    const Floats8 zero = (0.0f - Floats8{});
    const Ints8 firstColumn = (first + Ints8{}), lastColumn = (last + Ints8{});
    const Ints8 id = (triangle + Ints8{});
    const float* tileRow = occlusion.tileFarthest +
                           static_cast<size_t>(row / kTile) * occlusion.tilesX;
    for (int block = first & ~7; block <= last; block += 8) {
      // behind every pixel of the block's tile: nothing to take
      if (occlusion.nearest <= tileRow[block / kTile]) continue;
      Floats8 x, stored;
      Ints8 ids;
      std::memcpy(&x, columnX + block, sizeof x);
      std::memcpy(&stored, depthRow + block, sizeof stored);
      std::memcpy(&ids, visibleRow + block, sizeof ids);
      const Ints8 column = (block + Ints8{}) + kLanes;
      const Floats8 e0 = a0v * x + e0Row;
      const Floats8 e1 = a1v * x + e1Row;
      const Floats8 e2 = a2v * x + e2Row;
      const Floats8 s = asv * x + sRow;
      const Ints8 take = (e0 >= zero) & (e1 >= zero) & (e2 >= zero) &
                         (s > stored) & (column >= firstColumn) &
                         (column <= lastColumn);
      stored = take ? s : stored;
      ids = take ? id : ids;
      std::memcpy(depthRow + block, &stored, sizeof stored);
      std::memcpy(visibleRow + block, &ids, sizeof ids);
    }
  }
}

// Depth per pixel from the visibility buffer: 1 / inverse depth where a
// triangle is visible, 0 (no hit) elsewhere.
VLN_RASTER_CLONES void depthFromInverse(const float* __restrict inverseDepth,
                                        const int32_t* __restrict visible,
                                        size_t count, float* __restrict depth) {
  // eight lanes at a time (the source rows are padded to them), dividing in
  // every lane, by 1 where nothing is visible
  for (size_t first = 0; first < count; first += 8) {
    Floats8 stored;
    Ints8 shown;
    std::memcpy(&stored, inverseDepth + first, sizeof stored);
    std::memcpy(&shown, visible + first, sizeof shown);
    const Ints8 hit = shown >= (0 + Ints8{});
    const Floats8 inverse =
        (1.0f - Floats8{}) / (hit ? stored : (1.0f - Floats8{}));
    const Floats8 result = hit ? inverse : (0.0f - Floats8{});
    std::memcpy(depth + first, &result,
                sizeof(float) * std::min<size_t>(8, count - first));
  }
}

// Barycentrics (Embree's u and v: corner 1's and corner 2's) of the
// visible triangle at each pixel of one row, from its edge functions: each
// over their sum. `count` is a multiple of eight (the padded row). A run of
// eight pixels that shows one triangle is computed at once; others pixel by
// pixel (each reads its own triangle's functions), with the same operations.
VLN_RASTER_CLONES void rowBarycentrics(const EdgeFunctions* edges,
                                       const int32_t* visible,
                                       const float* columnX, float y,
                                       size_t count, float* u, float* v) {
  for (size_t first = 0; first < count; first += 8) {
    const int32_t shown = visible[first];
    bool one = shown >= 0;
    for (size_t k = 1; k < 8; ++k) one = one && visible[first + k] == shown;
    Floats8 e0, e1, e2;
    if (one) {
      const EdgeFunctions& f = edges[static_cast<size_t>(shown)];
      Floats8 x;
      std::memcpy(&x, columnX + first, sizeof x);
      e0 = (f.a[0] - Floats8{}) * x + ((f.b[0] * y + f.c[0]) - Floats8{});
      e1 = (f.a[1] - Floats8{}) * x + ((f.b[1] * y + f.c[1]) - Floats8{});
      e2 = (f.a[2] - Floats8{}) * x + ((f.b[2] * y + f.c[2]) - Floats8{});
    } else {
      for (size_t k = 0; k < 8; ++k) {
        const int32_t triangle = visible[first + k];
        if (triangle < 0) {
          // no hit: any finite barycentrics (the shader skips the lane)
          e0[k] = e1[k] = e2[k] = 1.0f;
          continue;
        }
        const EdgeFunctions& f = edges[static_cast<size_t>(triangle)];
        const float x = columnX[first + k];
        e0[k] = f.a[0] * x + (f.b[0] * y + f.c[0]);
        e1[k] = f.a[1] * x + (f.b[1] * y + f.c[1]);
        e2[k] = f.a[2] * x + (f.b[2] * y + f.c[2]);
      }
    }
    const Floats8 sum = e0 + e1 + e2;
    const Floats8 uk = e1 / sum;
    const Floats8 vk = e2 / sum;
    std::memcpy(u + first, &uk, sizeof uk);
    std::memcpy(v + first, &vk, sizeof vk);
  }
}

// The mesh's vertices in a camera frame (rotation `toCamera`, row-major,
// and eye `eye`), with their ray slopes (x / -z, y / -z) where they lie at
// least kNearBound in front of the eye (else 0 and not in front), from
// positions stored as three arrays. Written out component by component so
// that both clones compute the same bits.
VLN_RASTER_CLONES void transformVertices(
    const float* __restrict x, const float* __restrict y,
    const float* __restrict z, size_t count, const float toCamera[9],
    const float eye[3], float* __restrict cameraX, float* __restrict cameraY,
    float* __restrict cameraZ, float* __restrict slopeX,
    float* __restrict slopeY, int32_t* __restrict inFront) {
  const float r00 = toCamera[0], r01 = toCamera[1], r02 = toCamera[2];
  const float r10 = toCamera[3], r11 = toCamera[4], r12 = toCamera[5];
  const float r20 = toCamera[6], r21 = toCamera[7], r22 = toCamera[8];
  const float ex = eye[0], ey = eye[1], ez = eye[2];
  for (size_t v = 0; v < count; ++v) {
    const float dx = x[v] - ex;
    const float dy = y[v] - ey;
    const float dz = z[v] - ez;
    const float cx = r00 * dx + r01 * dy + r02 * dz;
    const float cy = r10 * dx + r11 * dy + r12 * dz;
    const float cz = r20 * dx + r21 * dy + r22 * dz;
    cameraX[v] = cx;
    cameraY[v] = cy;
    cameraZ[v] = cz;
    const bool front = cz <= -kNearBound;
    // a vertex not in front divides by 1 (its slopes are never read)
    const float depth = front ? -cz : 1.0f;
    slopeX[v] = front ? cx / depth : 0.0f;
    slopeY[v] = front ? cy / depth : 0.0f;
    inFront[v] = front ? 1 : 0;
  }
}

// The mesh's triangle count; throws std::invalid_argument when the
// visibility buffer's int32 entries cannot index them all.
size_t indexableTriangles(const TriangleMesh& mesh) {
  const size_t count = mesh.triangleCount();
  constexpr auto kMost =
      static_cast<size_t>(std::numeric_limits<int32_t>::max());
  VLN_CHECK_ARG(count < kMost, "RasterRenderer: the mesh has ", count,
                " triangles, more than the ", kMost - 1, " it can index");
  return count;
}

class RasterRenderer final : public Renderer {
 public:
  explicit RasterRenderer(const TriangleMesh& mesh)
      : Renderer("RasterRenderer", mesh),
        mesh_(mesh),
        edges_(indexableTriangles(mesh)) {
    for (const Vec3f& position : mesh.positions) {
      positionX_.push_back(position.x());
      positionY_.push_back(position.y());
      positionZ_.push_back(position.z());
    }
  }

 private:
  enum class EdgeState : uint8_t { kUnset, kSet, kEdgeOn };

  // A triangle that may show in the current view: its extent in ray slopes
  // (X, Y), a bound on its inverse depth (1 / the z-depth of its nearest
  // corner, slightly enlarged against rounding); its edge functions are
  // edges_[triangle].
  struct ViewTriangle {
    float minX, maxX, minY, maxY;
    float nearest;
    int32_t triangle;
    // edges_[triangle] holds this view's edge functions (set up when the
    // triangle is first drawn: most are hidden and never need them)
    EdgeState edges = EdgeState::kUnset;
  };

  void render(const CameraPose& pose, const CameraIntrinsics& camera,
              unsigned outputs, uint8_t* rgb, float* depth,
              int32_t* objects) override;
  void updateRayTable(const CameraIntrinsics& camera);
  // the triangles of the view from `pose` through the slope window
  // |X| <= tanX, |Y| <= tanY, near to far; kept while the pose and window
  // stay (the colour and depth cameras of one view share them, whatever
  // their sizes)
  void setUpView(const CameraPose& pose, float tanX, float tanY);
  // sets up triangle `t` when it reaches into the window
  void setUpTriangle(size_t t, float tanX, float tanY);
  // writes edges_[t] for the current view; false when the triangle is seen
  // edge-on (or degenerate) and covers no pixel centre
  bool setUpEdges(size_t t);
  // the colour image of the visibility buffer
  void shadeVisible(const CameraIntrinsics& camera, uint8_t* rgb);

  const TriangleMesh& mesh_;
  // the mesh's vertex positions as three arrays (for transformVertices())
  std::vector<float> positionX_;
  std::vector<float> positionY_;
  std::vector<float> positionZ_;
  // built on the first colour render: depth-only renderers never pay for it
  std::optional<HitShader> shader_;
  // per triangle, written when it is set up for the current view
  std::vector<EdgeFunctions> edges_;

  // camera-frame ray slopes per column (X) and row (Y) of the last
  // intrinsics, their extremes, and the maps from slopes back to
  // (fractional) pixels
  CameraIntrinsics tableCamera_{0, 0, 0.0f};
  std::vector<float> columnX_;
  std::vector<float> rowY_;
  size_t stride_ = 0;  // row stride of the visibility buffer: width padded to 8
  float tanX_ = 0.0f;
  float tanY_ = 0.0f;
  float columnScale_ = 0.0f;
  float columnOffset_ = 0.0f;
  float rowScale_ = 0.0f;
  float rowOffset_ = 0.0f;

  // the view set up last: pose, window, the vertices in its camera frame
  // with their slopes (x / -z, y / -z) where they lie at least kNearBound in
  // front of the eye, and its triangles
  bool haveView_ = false;
  CameraPose viewPose_;
  float viewTanX_ = 0.0f;
  float viewTanY_ = 0.0f;
  std::vector<float> cameraX_;
  std::vector<float> cameraY_;
  std::vector<float> cameraZ_;
  std::vector<float> slopeX_;
  std::vector<float> slopeY_;
  std::vector<int32_t> inFront_;
  Vec3f cameraVertex(uint32_t v) const {
    return {cameraX_[v], cameraY_[v], cameraZ_[v]};
  }
  std::vector<ViewTriangle> viewTriangles_;
  std::vector<ViewTriangle> sortedTriangles_;  // scratch of the sort

  // the visibility buffer: 1 / z-depth and triangle per pixel, and per tile
  // of kTile x kTile pixels the smallest inverse depth (the farthest hit, 0
  // while a pixel has none)
  std::vector<float> inverseDepth_;
  std::vector<int32_t> visible_;
  std::vector<float> tileFarthest_;
  std::vector<uint8_t> tileStale_;
  // one row's barycentrics while shading
  std::vector<float> barycentricRow_;
};

void RasterRenderer::updateRayTable(const CameraIntrinsics& camera) {
  if (camera.width == tableCamera_.width &&
      camera.height == tableCamera_.height &&
      camera.hfov_deg == tableCamera_.hfov_deg)
    return;
  // rows padded to whole blocks of eight columns (masked off when drawing)
  PixelSlopes slopes = pixelSlopes(camera, 8);
  columnX_ = std::move(slopes.columnX);
  rowY_ = std::move(slopes.rowY);
  stride_ = columnX_.size();
  // pixelDirection(): X = (2 (column + 0.5) / width - 1) tan(hfov / 2), so
  // column = X * width / (2 tan) + width / 2 - 0.5; rows count downwards
  tanX_ = std::tan(degToRad(camera.hfov_deg) / 2.0f);
  tanY_ = tanHalfVerticalFov(camera);
  columnScale_ = static_cast<float>(camera.width) / (2.0f * tanX_);
  columnOffset_ = static_cast<float>(camera.width) / 2.0f - 0.5f;
  rowScale_ = -static_cast<float>(camera.height) / (2.0f * tanY_);
  rowOffset_ = static_cast<float>(camera.height) / 2.0f - 0.5f;
  tableCamera_ = camera;
}

void RasterRenderer::setUpView(const CameraPose& pose, float tanX, float tanY) {
  if (haveView_ && pose.eye == viewPose_.eye &&
      pose.heading == viewPose_.heading && pose.pitch == viewPose_.pitch &&
      tanX == viewTanX_ && tanY == viewTanY_)
    return;
  const Eigen::Matrix3f rotation = cameraToWorld(pose).transpose();
  float toCamera[9];
  for (int row = 0; row < 3; ++row)
    for (int column = 0; column < 3; ++column)
      toCamera[3 * row + column] = rotation(row, column);
  const float eye[3] = {pose.eye.x(), pose.eye.y(), pose.eye.z()};
  const size_t count = positionX_.size();
  for (auto* buffer : {&cameraX_, &cameraY_, &cameraZ_, &slopeX_, &slopeY_})
    buffer->resize(count);
  inFront_.resize(count);
  transformVertices(positionX_.data(), positionY_.data(), positionZ_.data(),
                    count, toCamera, eye, cameraX_.data(), cameraY_.data(),
                    cameraZ_.data(), slopeX_.data(), slopeY_.data(),
                    inFront_.data());
  viewTriangles_.clear();
  const size_t triangles = mesh_.triangleCount();
  for (size_t t = 0; t < triangles; ++t) setUpTriangle(t, tanX, tanY);
  // near to far, so that near walls hide whole triangles behind them from
  // the tile test in render(): a counting sort into slices of depth (of
  // each triangle's nearest corner), mesh order within a slice
  constexpr int kSlices = 256;
  constexpr float kSlicesPerMetre = 16.0f;
  auto slice = [&](const ViewTriangle& view) {
    const float depth = 1.0f / view.nearest;  // 0 when unbounded
    // compared before the conversion: a far corner's depth may exceed any
    // int (and NaN from hostile coordinates goes last)
    const float scaled = depth * kSlicesPerMetre;
    return scaled < static_cast<float>(kSlices - 1) ? static_cast<int>(scaled) : kSlices - 1;
  };
  size_t start[kSlices + 1] = {};
  for (const ViewTriangle& view : viewTriangles_) ++start[slice(view) + 1];
  for (int k = 0; k < kSlices; ++k) start[k + 1] += start[k];
  sortedTriangles_.resize(viewTriangles_.size());
  for (const ViewTriangle& view : viewTriangles_)
    sortedTriangles_[start[slice(view)]++] = view;
  viewTriangles_.swap(sortedTriangles_);
  viewPose_ = pose;
  viewTanX_ = tanX;
  viewTanY_ = tanY;
  haveView_ = true;
}

void RasterRenderer::setUpTriangle(size_t t, float tanX, float tanY) {
  const uint32_t* corner = mesh_.indices.data() + 3 * t;
  const int front =
      inFront_[corner[0]] + inFront_[corner[1]] + inFront_[corner[2]];
  if (front == 0) return;  // wholly behind (or at) the eye
  // the triangle's extent in ray slopes: its corners' where all three lie in
  // front; otherwise those of the part of it at least kNearBound in front
  float minX = std::numeric_limits<float>::infinity();
  float maxX = -minX;
  float minY = minX;
  float maxY = -minX;
  auto extend = [&](float x, float y) {
    minX = std::min(minX, x);
    maxX = std::max(maxX, x);
    minY = std::min(minY, y);
    maxY = std::max(maxY, y);
  };
  if (front == 3) {
    for (int k = 0; k < 3; ++k) extend(slopeX_[corner[k]], slopeY_[corner[k]]);
  } else {
    for (int k = 0; k < 3; ++k) {
      const uint32_t from = corner[k];
      const uint32_t to = corner[(k + 1) % 3];
      if (inFront_[from]) extend(slopeX_[from], slopeY_[from]);
      if (inFront_[from] == inFront_[to]) continue;
      // where the edge crosses the plane z = -kNearBound
      const Vec3f p = cameraVertex(from);
      const Vec3f q = cameraVertex(to);
      const float along = (-kNearBound - p.z()) / (q.z() - p.z());
      const Vec3f crossing = p + along * (q - p);
      extend(crossing.x() / kNearBound, crossing.y() / kNearBound);
    }
  }
  // pixel centres lie strictly inside the window
  if (maxX < -tanX || minX > tanX || maxY < -tanY || minY > tanY) return;

  // the nearest corner bounds the triangle's inverse depth (z-depth is
  // linear over it); a corner not in front leaves it unbounded
  float nearest = std::numeric_limits<float>::infinity();
  if (front == 3) {
    const float closest = std::min(
        {-cameraZ_[corner[0]], -cameraZ_[corner[1]], -cameraZ_[corner[2]]});
    nearest = (1.0f + kNearestSlack) / closest;
  }
  viewTriangles_.push_back(
      {minX, maxX, minY, maxY, nearest, static_cast<int32_t>(t)});
}

bool RasterRenderer::setUpEdges(size_t t) {
  const uint32_t* corner = mesh_.indices.data() + 3 * t;
  // edge planes through the eye, in double so that the triangles sharing an
  // edge get exactly negated coefficients for it (the cross products of the
  // same two corners in either order), which keeps the edge watertight
  Eigen::Vector3d p[3];
  for (int k = 0; k < 3; ++k) p[k] = cameraVertex(corner[k]).cast<double>();
  const Eigen::Vector3d normal[3] = {p[1].cross(p[2]), p[2].cross(p[0]),
                                     p[0].cross(p[1])};
  const double det = p[0].dot(normal[0]);
  // the eye lies in the triangle's plane (or the triangle is degenerate):
  // seen edge-on, it covers no pixel centre
  if (!(det != 0.0) || !std::isfinite(det)) return false;
  const double sign = det > 0.0 ? 1.0 : -1.0;
  EdgeFunctions& f = edges_[t];
  double sum[3] = {0.0, 0.0, 0.0};
  for (int i = 0; i < 3; ++i) {
    // (x, y, z) . (X, Y, -1)
    const double a = sign * normal[i].x();
    const double b = sign * normal[i].y();
    const double c = -sign * normal[i].z();
    f.a[i] = static_cast<float>(a);
    f.b[i] = static_cast<float>(b);
    f.c[i] = static_cast<float>(c);
    sum[0] += a;
    sum[1] += b;
    sum[2] += c;
  }
  const double inverseDet = 1.0 / std::abs(det);
  f.a[3] = static_cast<float>(sum[0] * inverseDet);
  f.b[3] = static_cast<float>(sum[1] * inverseDet);
  f.c[3] = static_cast<float>(sum[2] * inverseDet);
  return true;
}

void RasterRenderer::render(const CameraPose& pose,
                            const CameraIntrinsics& camera, unsigned outputs,
                            uint8_t* rgb, float* depth, int32_t* objects) {
  updateRayTable(camera);
  setUpView(pose, tanX_, tanY_);
  if ((outputs & kColor) && !shader_) shader_.emplace(mesh_);
  const int width = camera.width;
  const int height = camera.height;
  const size_t stride = stride_;
  inverseDepth_.assign(stride * static_cast<size_t>(height), 0.0f);
  visible_.assign(stride * static_cast<size_t>(height), -1);

  // pixels whose centres may lie inside each triangle: a conservative
  // bound, the edge functions decide (NaN from hostile coordinates counts
  // as -1 rather than reaching the conversion)
  auto toPixel = [](float value, int size) {
    return value >= -1.0f ? static_cast<int>(std::min(value, static_cast<float>(size))) : -1;
  };
  const int tilesX = (width + kTile - 1) / kTile;
  const int tilesY = (height + kTile - 1) / kTile;
  tileFarthest_.assign(
      static_cast<size_t>(tilesX) * static_cast<size_t>(tilesY), 0.0f);
  tileStale_.assign(tileFarthest_.size(), 0);
  auto tileAt = [&](int tx, int ty) {
    return static_cast<size_t>(ty) * static_cast<size_t>(tilesX) +
           static_cast<size_t>(tx);
  };
  for (ViewTriangle& view : viewTriangles_) {
    // truncation floors the first row and column (negative ones become 0
    // anyway) and one more stands in for the ceiling of the last (no libm
    // calls in this loop)
    const PixelBounds bounds{
        std::max(0, toPixel(view.maxY * rowScale_ + rowOffset_, height)),
        std::min(height - 1,
                 toPixel(view.minY * rowScale_ + rowOffset_, height) + 1),
        std::max(0, toPixel(view.minX * columnScale_ + columnOffset_, width)),
        std::min(width - 1,
                 toPixel(view.maxX * columnScale_ + columnOffset_, width) + 1),
        columnScale_,
        columnOffset_};
    if (bounds.firstColumn > bounds.lastColumn ||
        bounds.firstRow > bounds.lastRow)
      continue;
    // a triangle whose nearest point is no nearer than the farthest hit of
    // every tile it overlaps cannot take a pixel (ties keep the stored hit)
    const int firstTileX = bounds.firstColumn / kTile;
    const int lastTileX = bounds.lastColumn / kTile;
    const int firstTileY = bounds.firstRow / kTile;
    const int lastTileY = bounds.lastRow / kTile;
    bool hidden = true;
    for (int ty = firstTileY; ty <= lastTileY && hidden; ++ty) {
      for (int tx = firstTileX; tx <= lastTileX; ++tx) {
        const size_t tile = tileAt(tx, ty);
        if (view.nearest <= tileFarthest_[tile]) continue;
        // drawn into since its farthest hit was taken: the bound may have
        // grown
        if (tileStale_[tile]) {
          tileFarthest_[tile] =
              farthestInTile(inverseDepth_.data(), stride, tx * kTile,
                             ty * kTile, std::min(kTile, width - tx * kTile),
                             std::min(kTile, height - ty * kTile));
          tileStale_[tile] = 0;
          if (view.nearest <= tileFarthest_[tile]) continue;
        }
        hidden = false;
        break;
      }
    }
    if (hidden) continue;
    if (view.edges == EdgeState::kUnset)
      view.edges = setUpEdges(static_cast<size_t>(view.triangle))
                       ? EdgeState::kSet
                       : EdgeState::kEdgeOn;
    if (view.edges == EdgeState::kEdgeOn) continue;
    rasterizeTriangle(
        columnX_.data(), rowY_.data(),
        edges_[static_cast<size_t>(view.triangle)], bounds,
        {tileFarthest_.data(), static_cast<size_t>(tilesX), view.nearest},
        view.triangle, stride, inverseDepth_.data(), visible_.data());
    // a tile already farther than this triangle's nearest point kept every
    // pixel; the others' farthest hit is taken again when next needed
    for (int ty = firstTileY; ty <= lastTileY; ++ty)
      for (int tx = firstTileX; tx <= lastTileX; ++tx)
        if (view.nearest > tileFarthest_[tileAt(tx, ty)])
          tileStale_[tileAt(tx, ty)] = 1;
  }

  // resolve the visibility buffer
  const auto& triangleObject = mesh_.triangle_object;
  for (int row = 0; row < height; ++row) {
    const size_t from = static_cast<size_t>(row) * stride;
    const size_t to = static_cast<size_t>(row) * static_cast<size_t>(width);
    if (outputs & kDepth)
      depthFromInverse(inverseDepth_.data() + from, visible_.data() + from,
                       static_cast<size_t>(width), depth + to);
    if (outputs & kObject) {
      for (int column = 0; column < width; ++column) {
        const int32_t triangle = visible_[from + static_cast<size_t>(column)];
        objects[to + static_cast<size_t>(column)] =
            (triangle < 0 || triangleObject.empty())
                ? -1
                : triangleObject[static_cast<size_t>(triangle)];
      }
    }
  }
  if (outputs & kColor) shadeVisible(camera, rgb);
}

void RasterRenderer::shadeVisible(const CameraIntrinsics& camera,
                                  uint8_t* rgb) {
  const int width = camera.width;
  // per row: the barycentrics of every pixel's visible triangle, then the
  // shader eight pixels at a time
  const size_t padded = stride_;
  barycentricRow_.resize(2 * padded);
  float* u = barycentricRow_.data();
  float* v = u + padded;
  for (int row = 0; row < camera.height; ++row) {
    const size_t rowStart =
        static_cast<size_t>(row) * static_cast<size_t>(width);
    const int32_t* visible =
        visible_.data() + static_cast<size_t>(row) * stride_;
    rowBarycentrics(edges_.data(), visible, columnX_.data(),
                    rowY_[static_cast<size_t>(row)], padded, u, v);
    for (int first = 0; first < width; first += 8) {
      const int lanes = std::min(8, width - first);
      alignas(32) uint32_t triangles[8] = {};
      unsigned hits = 0;
      for (int k = 0; k < lanes; ++k) {
        const int32_t triangle = visible[first + k];
        if (triangle < 0) continue;
        triangles[k] = static_cast<uint32_t>(triangle);
        hits |= 1u << k;
      }
      alignas(32) uint32_t colors[8];
      shader_->shade8(triangles, u + first, v + first, hits, colors);
      uint8_t* out = rgb + 3 * (rowStart + static_cast<size_t>(first));
      for (int k = 0; k < lanes; ++k) writeColor(colors[k], out + 3 * k);
    }
  }
}

}  // namespace

std::unique_ptr<Renderer> createRasterRenderer(const TriangleMesh& mesh) {
  return std::make_unique<RasterRenderer>(mesh);
}

}  // namespace vln::sim
