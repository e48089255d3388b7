#include "sim/TopDownMap.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>

#include "common/Check.h"
#include "common/FileIo.h"
#include "sim/GeometryCheck.h"
#include "sim/Scene.h"

namespace vln::sim {

namespace {

// Map palette (RGB). Navigable space is light and obstacles dark, as in
// Habitat's top-down maps; the outside of the scene stays white.
const cv::Scalar kOutside(255, 255, 255);
const cv::Scalar kObstacle(120, 120, 120);
const cv::Scalar kWall(45, 45, 45);
const cv::Scalar kNavigable(232, 232, 232);
const cv::Scalar kLabel(0, 0, 0);

// Navmesh triangles within this height of the chosen floor belong to it:
// enough for ramps and thresholds, less than a table top (~0.7 m), so
// islands on furniture are not drawn as floor.
constexpr float kFloorBand = 0.5f;
// Blank border around the navigable area, metres: walls and objects at its
// edge stay on the canvas.
constexpr float kMargin = 0.5f;
// Objects whose bottom is higher above the floor than this (metres) hang on
// walls and get no label.
constexpr float kLabelMaxBase = 0.3f;
// Canvases beyond this many pixels mean a wrong scale, not a real map.
constexpr double kMaxPixels = 64.0 * 1024.0 * 1024.0;
// OpenCV drawing with 4 fractional bits keeps sub-pixel vertex positions.
constexpr int kShift = 4;
constexpr double kSubpixel = 1 << kShift;

cv::Scalar toScalar(Rgb8 color) {
  return cv::Scalar(color[0], color[1], color[2]);
}

// Colour an object is drawn in: its triangles' mean base x vertex colour,
// so the map shows what the camera sees; mid grey when it has no triangles.
std::map<int, cv::Scalar> objectColors(const TriangleMesh& mesh) {
  struct Sum {
    double r = 0, g = 0, b = 0;
    int n = 0;
  };
  std::map<int, Sum> sums;
  for (size_t t = 0; t < mesh.triangle_object.size(); ++t) {
    const int object = mesh.triangle_object[t];
    if (object < 0) continue;
    std::array<float, 3> base{1.0f, 1.0f, 1.0f};
    if (!mesh.triangle_material.empty() && mesh.triangle_material[t] >= 0)
      base = mesh.materials[static_cast<size_t>(mesh.triangle_material[t])]
                 .base_color;
    Sum& sum = sums[object];
    for (int k = 0; k < 3; ++k) {
      Rgb8 c{255, 255, 255};
      if (!mesh.colors.empty()) c = mesh.colors[mesh.indices[3 * t + k]];
      sum.r += base[0] * c[0];
      sum.g += base[1] * c[1];
      sum.b += base[2] * c[2];
      ++sum.n;
    }
  }
  std::map<int, cv::Scalar> colors;
  for (const auto& [object, sum] : sums)
    colors[object] = cv::Scalar(sum.r / sum.n, sum.g / sum.n, sum.b / sum.n);
  return colors;
}

// The navmesh level nearest a height, its triangles and their x-z bounds.
struct Floor {
  float level = 0.0f;
  std::vector<std::array<Vec3f, 3>> triangles;
  Eigen::AlignedBox2f area;
};

Floor findFloor(const Scene& scene, float floorY) {
  VLN_CHECK_ARG(std::isfinite(floorY),
                "TopDownMap: floorY must be finite, got ", floorY);
  const std::vector<std::array<Vec3f, 3>> triangles =
      scene.navmesh().triangles();
  VLN_CHECK_ARG(!triangles.empty(), "TopDownMap: scene '", scene.name(),
                "' has an empty navmesh");
  Floor floor;
  floor.level = triangles.front()[0].y();
  for (const auto& tri : triangles) {
    const float y = (tri[0].y() + tri[1].y() + tri[2].y()) / 3.0f;
    if (std::abs(y - floorY) < std::abs(floor.level - floorY)) floor.level = y;
  }
  for (const auto& tri : triangles) {
    const float y = (tri[0].y() + tri[1].y() + tri[2].y()) / 3.0f;
    if (std::abs(y - floor.level) > kFloorBand) continue;
    floor.triangles.push_back(tri);
    for (const Vec3f& p : tri) floor.area.extend(Vec2f(p.x(), p.z()));
  }
  return floor;
}

// Label text: small enough for furniture names beside furniture, large
// enough to read on a 1,000-pixel map.
constexpr int kLabelFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kLabelScale = 0.4;
// gap between an object's box and its label, and around placed labels
constexpr int kLabelGap = 3;

struct LabelRequest {
  std::string text;
  cv::Rect object;  // the object's box in pixels
};

bool overlapsAny(const cv::Rect& box, const std::vector<cv::Rect>& others) {
  for (const cv::Rect& other : others)
    if ((box & other).area() > 0) return true;
  return false;
}

// Places each label beside its object (right, left, above, below, then on
// it), in the first place on the canvas that overlaps no placed label and,
// when possible, no other object; draws it with a halo. Larger objects go
// first: they are the landmarks instructions name most.
void placeLabels(cv::Mat& image, std::vector<LabelRequest> requests,
                 std::vector<MapLabel>& placed,
                 std::vector<std::string>& dropped) {
  std::stable_sort(requests.begin(), requests.end(),
                   [](const LabelRequest& a, const LabelRequest& b) {
                     return a.object.area() > b.object.area();
                   });
  std::vector<cv::Rect> objects;
  for (const LabelRequest& r : requests) objects.push_back(r.object);
  const cv::Rect canvas(0, 0, image.cols, image.rows);
  std::vector<cv::Rect> taken;
  for (size_t i = 0; i < requests.size(); ++i) {
    const LabelRequest& request = requests[i];
    int baseline = 0;
    const cv::Size text =
        cv::getTextSize(request.text, kLabelFont, kLabelScale, 1, &baseline);
    const int w = text.width + 2;
    const int h = text.height + baseline + 2;
    const cv::Rect& o = request.object;
    const int midX = o.x + o.width / 2 - w / 2;
    const int midY = o.y + o.height / 2 - h / 2;
    const cv::Rect candidates[] = {
        {o.x + o.width + kLabelGap, midY, w, h},   // right
        {o.x - kLabelGap - w, midY, w, h},         // left
        {midX, o.y - kLabelGap - h, w, h},         // above
        {midX, o.y + o.height + kLabelGap, w, h},  // below
        {midX, midY, w, h},                        // on the object
    };
    std::vector<cv::Rect> otherObjects;
    for (size_t j = 0; j < objects.size(); ++j)
      if (j != i) otherObjects.push_back(objects[j]);
    const cv::Rect* chosen = nullptr;
    for (int pass = 0; pass < 2 && chosen == nullptr; ++pass) {
      for (const cv::Rect& c : candidates) {
        if ((c & canvas) != c) continue;
        const cv::Rect padded(c.x - 1, c.y - 1, c.width + 2, c.height + 2);
        if (overlapsAny(padded, taken)) continue;
        if (pass == 0 && overlapsAny(c, otherObjects)) continue;
        chosen = &c;
        break;
      }
    }
    if (chosen == nullptr) {
      dropped.push_back(request.text);
      continue;
    }
    taken.push_back(*chosen);
    placed.push_back(
        {request.text, chosen->x, chosen->y, chosen->width, chosen->height});
    const cv::Point origin(chosen->x + 1, chosen->y + 1 + text.height);
    cv::putText(image, request.text, origin, kLabelFont, kLabelScale,
                cv::Scalar(255, 255, 255), 3, cv::LINE_AA);
    cv::putText(image, request.text, origin, kLabelFont, kLabelScale, kLabel, 1,
                cv::LINE_AA);
  }
}

}  // namespace

struct TopDownMap::Impl {
  float metersPerPixel = 0.05f;
  float minX = 0.0f;
  float minZ = 0.0f;
  std::vector<uint8_t> rgb;
  cv::Mat image;  // CV_8UC3 view of rgb, channels in RGB order
  // the navmesh's query box: where drawn points may lie (a point at 1e30
  // overflows the int pixel coordinates)
  Eigen::AlignedBox3f accepted;
  std::vector<MapLabel> placedLabels;
  std::vector<std::string> droppedLabels;

  // continuous map coordinates in OpenCV's fixed-point convention (integer
  // = pixel centre)
  cv::Point fixedPoint(const Vec3f& p) const {
    const double u = (p.x() - minX) / metersPerPixel - 0.5;
    const double v = (p.z() - minZ) / metersPerPixel - 0.5;
    return {static_cast<int>(std::lround(u * kSubpixel)),
            static_cast<int>(std::lround(v * kSubpixel))};
  }
  cv::Point pixel(const Vec3f& p) const {
    return {static_cast<int>(std::floor((p.x() - minX) / metersPerPixel)),
            static_cast<int>(std::floor((p.z() - minZ) / metersPerPixel))};
  }
};

TopDownMap::TopDownMap(const Scene& scene, float metersPerPixel, float floorY)
    : impl_(std::make_unique<Impl>()) {
  VLN_CHECK_ARG(std::isfinite(metersPerPixel) && metersPerPixel > 0.0f,
                "TopDownMap: metersPerPixel must be positive, got ",
                metersPerPixel);
  impl_->metersPerPixel = metersPerPixel;
  impl_->accepted = scene.navmesh().queryBounds();
  const Floor floor = findFloor(scene, floorY);
  const float level = floor.level;
  const Eigen::AlignedBox2f& area = floor.area;

  // canvas: the floor's navigable bounds plus a margin
  impl_->minX = area.min().x() - kMargin;
  impl_->minZ = area.min().y() - kMargin;
  const double width =
      std::ceil((area.sizes().x() + 2 * kMargin) / metersPerPixel);
  const double height =
      std::ceil((area.sizes().y() + 2 * kMargin) / metersPerPixel);
  VLN_CHECK_ARG(width * height <= kMaxPixels, "TopDownMap: scene '",
                scene.name(), "' at ", metersPerPixel, " m/pixel needs a ",
                width, "x", height, " canvas; use a coarser metersPerPixel");
  impl_->rgb.assign(static_cast<size_t>(width * height * 3), 255);
  impl_->image = cv::Mat(static_cast<int>(height), static_cast<int>(width),
                         CV_8UC3, impl_->rgb.data());
  cv::Mat& image = impl_->image;
  image.setTo(kOutside);

  // obstacles: whatever of the scene's footprint is not navigable
  const Eigen::AlignedBox3f meshBounds = scene.mesh().bounds();
  cv::rectangle(
      image, impl_->pixel(Vec3f(meshBounds.min().x(), 0, meshBounds.min().z())),
      impl_->pixel(Vec3f(meshBounds.max().x(), 0, meshBounds.max().z())),
      kObstacle, cv::FILLED);

  // navigable area of this floor
  for (const auto& tri : floor.triangles) {
    const cv::Point corners[3] = {impl_->fixedPoint(tri[0]),
                                  impl_->fixedPoint(tri[1]),
                                  impl_->fixedPoint(tri[2])};
    cv::fillConvexPoly(image, corners, 3, kNavigable, cv::LINE_8, kShift);
  }

  // walls: steep scene triangles that stand in this floor's storey, drawn
  // as their footprint outline
  const TriangleMesh& mesh = scene.mesh();
  const float storeyTop = level + scene.navmesh().config().agent_height;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    const Vec3f& a = mesh.positions[mesh.indices[3 * t]];
    const Vec3f& b = mesh.positions[mesh.indices[3 * t + 1]];
    const Vec3f& c = mesh.positions[mesh.indices[3 * t + 2]];
    const float low = std::min({a.y(), b.y(), c.y()});
    const float high = std::max({a.y(), b.y(), c.y()});
    if (high < level + 0.1f || low > storeyTop) continue;
    const Vec3f normal = (b - a).cross(c - a);
    const float length = normal.norm();
    if (length <= 0.0f || std::abs(normal.y()) / length > 0.3f) continue;
    const cv::Point corners[3] = {impl_->fixedPoint(a), impl_->fixedPoint(b),
                                  impl_->fixedPoint(c)};
    const cv::Point* polygon = corners;
    const int count = 3;
    cv::polylines(image, &polygon, &count, 1, /*isClosed=*/true, kWall,
                  /*thickness=*/1, cv::LINE_8, kShift);
  }

  // semantic objects standing on this floor: boxes in their colour, labelled
  const auto colors = objectColors(mesh);
  std::vector<LabelRequest> labels;
  for (const SemanticObject& object : scene.semantics().objects) {
    if (object.bounds.isEmpty()) continue;
    if (object.bounds.max().y() < level - kFloorBand ||
        object.bounds.min().y() > storeyTop)
      continue;
    const auto found = colors.find(object.id);
    const cv::Scalar fill =
        found != colors.end() ? found->second : cv::Scalar(128, 128, 128);
    const cv::Point lo = impl_->pixel(object.bounds.min());
    const cv::Point hi = impl_->pixel(object.bounds.max());
    cv::rectangle(image, lo, hi, fill, cv::FILLED);
    cv::rectangle(image, lo, hi, kWall, 1);
    // only furniture standing on the floor is labelled: windows and pictures
    // on the walls would bury the map in overlapping text
    if (object.bounds.min().y() < level + kLabelMaxBase)
      labels.push_back({object.category, cv::Rect(lo, hi)});
  }
  placeLabels(image, std::move(labels), impl_->placedLabels,
              impl_->droppedLabels);
}

float TopDownMap::metersPerPixelForLongSide(const Scene& scene, float floorY,
                                            int longSidePixels) {
  VLN_CHECK_ARG(longSidePixels >= 16,
                "TopDownMap: the long side must be >= 16 pixels, got ",
                longSidePixels);
  const Floor floor = findFloor(scene, floorY);
  const float longSide =
      std::max(floor.area.sizes().x(), floor.area.sizes().y()) + 2 * kMargin;
  // a hair coarser, so rounding the canvas up never adds a pixel
  return longSide / static_cast<float>(longSidePixels) * 1.0001f;
}

TopDownMap::~TopDownMap() = default;
TopDownMap::TopDownMap(TopDownMap&&) noexcept = default;
TopDownMap& TopDownMap::operator=(TopDownMap&&) noexcept = default;

void TopDownMap::drawPath(const std::vector<Vec3f>& points, Rgb8 color,
                          int thickness) {
  if (points.empty()) return;
  std::vector<cv::Point> polyline;
  polyline.reserve(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    checkPosition("TopDownMap::drawPath()", strCat("point ", i), points[i],
                  impl_->accepted);
    polyline.push_back(impl_->fixedPoint(points[i]));
  }
  if (polyline.size() == 1) {
    cv::circle(impl_->image, polyline[0],
               std::max(1, thickness) * (1 << kShift) / 2, toScalar(color),
               cv::FILLED, cv::LINE_AA, kShift);
    return;
  }
  cv::polylines(impl_->image, polyline, /*isClosed=*/false, toScalar(color),
                std::max(1, thickness), cv::LINE_AA, kShift);
}

void TopDownMap::drawPoint(const Vec3f& p, Rgb8 color, int radiusPixels) {
  checkPosition("TopDownMap::drawPoint()", "point", p, impl_->accepted);
  cv::circle(impl_->image, impl_->fixedPoint(p),
             std::max(1, radiusPixels) * (1 << kShift), toScalar(color),
             cv::FILLED, cv::LINE_AA, kShift);
}

void TopDownMap::drawCircle(const Vec3f& center, float radiusMeters, Rgb8 color,
                            int thickness) {
  VLN_CHECK_ARG(std::isfinite(radiusMeters) && radiusMeters >= 0.0f,
                "TopDownMap::drawCircle(): radius must be >= 0, got ",
                radiusMeters);
  checkPosition("TopDownMap::drawCircle()", "centre", center, impl_->accepted);
  const int radius = static_cast<int>(
      std::lround(radiusMeters / impl_->metersPerPixel * kSubpixel));
  cv::circle(impl_->image, impl_->fixedPoint(center), radius, toScalar(color),
             std::max(1, thickness), cv::LINE_AA, kShift);
}

void TopDownMap::drawAgent(const Vec3f& p, float heading, Rgb8 color) {
  checkPosition("TopDownMap::drawAgent()", "agent position", p,
                impl_->accepted);
  VLN_CHECK_ARG(std::isfinite(heading),
                "TopDownMap::drawAgent(): heading must be finite, got ",
                heading);
  // a disc the size of the agent (0.1 m radius) and an arrow 0.5 m long
  // along the heading, both kept visible on coarse maps
  const float mpp = impl_->metersPerPixel;
  const int body = std::max(3, static_cast<int>(std::lround(0.1f / mpp)));
  const int arrow =
      std::max(2 * body + 2, static_cast<int>(std::lround(0.5f / mpp)));
  const Vec3f tip =
      p + (static_cast<float>(arrow) * mpp) * headingToForward(heading);
  cv::circle(impl_->image, impl_->fixedPoint(p), body * (1 << kShift),
             toScalar(color), cv::FILLED, cv::LINE_AA, kShift);
  cv::arrowedLine(impl_->image, impl_->fixedPoint(p), impl_->fixedPoint(tip),
                  toScalar(color), std::max(2, body / 2), cv::LINE_AA, kShift,
                  /*tipLength=*/0.35);
}

void TopDownMap::drawText(const Vec3f& p, const std::string& text, Rgb8 color) {
  checkPosition("TopDownMap::drawText()", "point", p, impl_->accepted);
  // centred on the point, in a small fixed font
  constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
  constexpr double kScale = 0.35;
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, kScale, 1, &baseline);
  const cv::Point centre = impl_->pixel(p);
  cv::putText(impl_->image, text,
              cv::Point(centre.x - size.width / 2, centre.y + size.height / 2),
              kFont, kScale, toScalar(color), 1, cv::LINE_AA);
}

Eigen::Vector2i TopDownMap::toPixel(const Vec3f& p) const {
  checkPosition("TopDownMap::toPixel()", "point", p, impl_->accepted);
  const cv::Point pixel = impl_->pixel(p);
  return {pixel.x, pixel.y};
}

float TopDownMap::metersPerPixel() const { return impl_->metersPerPixel; }
const std::vector<MapLabel>& TopDownMap::placedLabels() const {
  return impl_->placedLabels;
}
const std::vector<std::string>& TopDownMap::droppedLabels() const {
  return impl_->droppedLabels;
}
int TopDownMap::width() const { return impl_->image.cols; }
int TopDownMap::height() const { return impl_->image.rows; }
const std::vector<uint8_t>& TopDownMap::rgb() const { return impl_->rgb; }

void TopDownMap::save(const std::filesystem::path& file) const {
  // OpenCV encodes BGR; the canvas is RGB
  cv::Mat bgr;
  cv::cvtColor(impl_->image, bgr, cv::COLOR_RGB2BGR);
  std::vector<uint8_t> png;
  VLN_CHECK_IO(cv::imencode(".png", bgr, png),
               "TopDownMap::save(): ", file.string(), ": PNG encoding failed");
  common::writeFileAtomic(
      file,
      std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
}

}  // namespace vln::sim
