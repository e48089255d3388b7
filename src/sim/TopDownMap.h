#pragma once
// Top-down maps of a scene (navmesh, walls, objects) with paths and markers
// drawn on top, written as PNG with OpenCV.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "common/Math.h"
#include "sim/Mesh.h"

namespace vln::sim {

class Scene;

/// An object label on the map: its text and the pixel box it occupies
/// (x, y = top-left corner).
struct MapLabel {
  std::string text;
  int x = 0;
  int y = 0;
  int width = 0;
  int height = 0;
};

/// An RGB canvas covering the scene's navmesh bounds in the x-z plane (plus
/// a 0.5 m margin): column = (x - min_x) / metersPerPixel, row = (z - min_z)
/// / metersPerPixel, so heading 0 (-Z) points up the image. Object labels are
/// placed beside their object where they overlap no other label and stay on
/// the canvas (a label with no such place is left out: see droppedLabels()),
/// in dark text on a light halo so they read over any background. Points given
/// to the draw methods and toPixel() must be finite and within the navmesh's
/// queryBounds() (beyond the canvas is fine: nothing is drawn there), and
/// headings finite; std::invalid_argument names the method otherwise.
class TopDownMap {
 public:
  /// Rasterises navigable area (light), obstacles/walls (dark) and semantic
  /// objects (their mean vertex colour; floor-standing ones labelled) at
  /// `metersPerPixel`, for the floor nearest to height `floorY` (navmesh
  /// triangles within 0.5 m of that level). Throws std::invalid_argument for
  /// a non-positive scale or a canvas beyond 64 Mpixels.
  TopDownMap(const Scene& scene, float metersPerPixel = 0.05f,
             float floorY = 0.0f);
  /// The scale at which the map of the floor nearest `floorY` (margin
  /// included) is `longSidePixels` on its long side. Throws
  /// std::invalid_argument for longSidePixels < 16 or an empty navmesh.
  static float metersPerPixelForLongSide(const Scene& scene, float floorY,
                                         int longSidePixels);
  ~TopDownMap();
  TopDownMap(TopDownMap&&) noexcept;
  TopDownMap& operator=(TopDownMap&&) noexcept;

  /// Draws a polyline through world points.
  void drawPath(const std::vector<Vec3f>& points, Rgb8 color,
                int thickness = 2);
  /// Draws a filled disc of `radiusPixels` at a world point.
  void drawPoint(const Vec3f& p, Rgb8 color, int radiusPixels = 4);
  /// Draws a circle of `radiusMeters` around a world point (e.g. the 3 m
  /// success radius).
  void drawCircle(const Vec3f& center, float radiusMeters, Rgb8 color,
                  int thickness = 1);
  /// Draws an arrow for an agent at `p` facing `heading`.
  void drawAgent(const Vec3f& p, float heading, Rgb8 color);
  /// Writes text at a world point.
  void drawText(const Vec3f& p, const std::string& text, Rgb8 color);

  /// Pixel (column, row) of a world point.
  Eigen::Vector2i toPixel(const Vec3f& p) const;
  float metersPerPixel() const;
  /// Object labels drawn, in drawing order, and the texts of those that
  /// found no free place.
  const std::vector<MapLabel>& placedLabels() const;
  const std::vector<std::string>& droppedLabels() const;
  int width() const;
  int height() const;
  /// The image, [height, width, 3] RGB uint8, row-major.
  const std::vector<uint8_t>& rgb() const;
  /// Saves as PNG (atomically). Throws std::runtime_error naming the file.
  void save(const std::filesystem::path& file) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vln::sim
