#pragma once
// Internal stages of the procedural house generator (see HouseGenerator.h):
// a portable random number generator, the floor plan, furniture placement
// and mesh building with baked lighting. Not part of the public world API;
// only the HouseBuilder*.cpp, ProceduralTextures.cpp and HouseGenerator.cpp
// files include it.
//
// Everything here must give bit-identical results on every machine: random
// numbers come from Rng (never std:: distributions), and geometry uses only
// + - * / and sqrt (IEEE-exact), never sin/cos/pow/exp whose last bits vary
// between C libraries.

#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "sim/Mesh.h"
#include "world/HouseGenerator.h"

namespace vln::world::house {

// The builder fills the simulator's mesh and semantic types.
using sim::Doorway;
using sim::Material;
using sim::Rgb8;
using sim::SemanticObject;
using sim::Texture;
using sim::TriangleMesh;

// ===========================================================================
// random numbers
// ===========================================================================

/// PCG32 (XSH-RR output, O'Neill 2014) seeded through splitmix64. Uniform
/// helpers are built from the raw bits by hand so their results do not
/// depend on the standard library.
class Rng {
 public:
  /// A generator for `seed`; `stream` selects an independent sequence.
  explicit Rng(uint64_t seed, uint64_t stream = 0);
  /// 32 uniformly random bits.
  uint32_t next();
  /// 64 uniformly random bits: the first next() is the high half, the
  /// second the low half (sequenced here, where `(next() << 32) | next()`
  /// would leave the order to the compiler).
  uint64_t next64();
  /// Uniform in [0, 1), 24-bit resolution.
  float uniform();
  /// Uniform in [lo, hi).
  float uniform(float lo, float hi);
  /// Uniform integer in [lo, hi] (inclusive), unbiased.
  int intIn(int lo, int hi);
  /// True with probability p.
  bool chance(float p);
  /// A child generator whose sequence is independent of this one's future
  /// draws (changing one stage never shifts another's numbers).
  Rng fork(uint64_t salt);
  /// A random index weighted by `weights` (non-negative, not all zero).
  int weighted(const std::vector<float>& weights);
  /// Fisher-Yates shuffle.
  template <class T>
  void shuffle(std::vector<T>& items) {
    for (int i = static_cast<int>(items.size()) - 1; i > 0; --i)
      std::swap(items[i], items[intIn(0, i)]);
  }

 private:
  uint64_t state_ = 0;
  uint64_t increment_ = 1;
};

// ===========================================================================
// floor plan (integer centimetres, so neighbouring walls meet exactly)
// ===========================================================================

/// Axis-aligned rectangle in the horizontal plane: x in [x0, x1], z in
/// [z0, z1], centimetres.
struct RectCm {
  int x0 = 0, z0 = 0, x1 = 0, z1 = 0;
  int width() const { return x1 - x0; }  ///< extent along x
  int depth() const { return z1 - z0; }  ///< extent along z
  int64_t area() const { return int64_t{width()} * depth(); }
};

/// A room of the plan: its cell runs to the wall centre lines, so the cells
/// of a house tile its outline without gaps or overlaps.
struct PlanRoom {
  std::string type;
  RectCm cell;
};

/// A doorway in the wall line between two rooms.
struct PlanDoor {
  int room_a = -1;
  int room_b = -1;
  /// True when the wall runs along x (the line is z = line_cm); false when it
  /// runs along z (the line is x = line_cm).
  bool along_x = true;
  int line_cm = 0;
  int center_cm = 0;  ///< centre of the opening along the wall
  int width_cm = 0;
};

struct FloorPlan {
  std::vector<PlanRoom> rooms;
  std::vector<PlanDoor> doors;
};

/// Lays out rooms (typed), walls' doorways and returns the plan; every room
/// is reachable through doorways. Throws std::invalid_argument when the
/// config cannot produce a valid plan (e.g. doors wider than rooms).
FloorPlan planFloor(Rng& rng, const HouseConfig& config);

/// Door opening along the wall as [lo, hi] centimetres.
inline std::array<int, 2> doorSpanCm(const PlanDoor& door) {
  return {door.center_cm - door.width_cm / 2,
          door.center_cm + door.width_cm - door.width_cm / 2};
}

/// The semantic record of a plan door (centre at floor height, metres).
Doorway toDoorway(const PlanDoor& door);

// ===========================================================================
// appearance
// ===========================================================================

/// Surface finishes; each is one material (and one procedural texture).
enum class Surface : int {
  kPlain = 0,
  kWoodFloor,
  kTiles,
  kCarpet,
  kWallpaper,
  kPlaster,
  kWood,
  kFabric,
  kCount
};

/// Real-world size (metres) of one repeat of each surface's texture; uvs
/// are world coordinates divided by it.
float surfacePeriod(Surface surface);
/// Material/texture name of a surface.
const char* surfaceName(Surface surface);

/// How one room looks.
struct RoomStyle {
  Rgb8 wall{230, 230, 225};
  Surface wall_surface = Surface::kPlaster;
  Rgb8 floor{180, 140, 100};
  Surface floor_surface = Surface::kWoodFloor;
  Rgb8 ceiling{240, 240, 236};
  Rgb8 trim{240, 240, 236};  ///< skirting boards and door frames
  std::array<float, 3> tint{1.0f, 1.0f, 1.0f};  ///< light colour in the room
};

/// Per-house appearance: one style per room plus shared textures.
struct HouseStyle {
  std::vector<RoomStyle> rooms;
  Rgb8 exterior{200, 196, 188};
};

/// Picks wall, floor and light styles for every room of `plan`.
HouseStyle chooseStyle(Rng& rng, const FloorPlan& plan);

/// Procedural RGB8 texture of `surface` (near-white pattern, multiplied
/// with vertex colours); `detail` in [0, 1] scales the pattern's contrast.
Texture makeSurfaceTexture(Surface surface, Rng& rng, float detail);

// ===========================================================================
// mesh building with baked lighting
// ===========================================================================

/// Shape of a furniture part; each fills its bounding box exactly (its
/// extreme vertices touch every face of the box).
enum class Shape {
  kBox,
  kCylinderY,  ///< axis along y
  kCylinderX,  ///< axis along x
  kCylinderZ,  ///< axis along z
  kConeY,      ///< base at min y, apex at max y
  kFrustumY,   ///< truncated cone: bottom radius full, top radius half
  kSphere,     ///< ellipsoid inscribed in the box
};

/// One coloured primitive of a furniture model or the house structure.
struct Part {
  Shape shape = Shape::kBox;
  Eigen::AlignedBox3f box;  ///< metres (local or world frame, by context)
  Rgb8 color{255, 255, 255};
  Surface surface = Surface::kPlain;
};

/// Appends geometry to a mesh with lighting baked into vertex colours:
/// ambient plus a fixed key and fill light on the face normal, a contact
/// term darkening parts near the floor, and the room's light tint.
class MeshBuilder {
 public:
  /// `withUvs`: emit texture coordinates (false when textures are off).
  MeshBuilder(TriangleMesh& mesh, bool withUvs);

  /// Current semantic object id (-1 = structure) and room light tint.
  void setObject(int object) { object_ = object; }
  void setTint(const std::array<float, 3>& tint) { tint_ = tint; }

  /// A planar quad a-b-c-d (counter-clockwise seen from the front, which
  /// faces `normal`); `shade` multiplies each corner's light (ambient
  /// occlusion), applied on top of the normal's light.
  void quad(const std::array<Vec3f, 4>& corners, const Vec3f& normal,
            const Rgb8& color, Surface surface,
            const std::array<float, 4>& shade = {1.0f, 1.0f, 1.0f, 1.0f});
  /// An axis-aligned rectangle subdivided at `cuts` along its two in-plane
  /// axes, with per-vertex shade from `shadeAt(point)`; normal is +-axis.
  /// `lo`/`hi` are the rectangle's corners (equal along `axis`).
  template <class ShadeFn>
  void grid(const Vec3f& lo, const Vec3f& hi, int axis, int sign,
            const std::vector<float>& cutsU, const std::vector<float>& cutsV,
            const Rgb8& color, Surface surface, ShadeFn shadeAt,
            const std::vector<Eigen::AlignedBox2f>& holes = {});
  /// A world-frame part (box faces skip `skipFaces`: bit 2*axis+(max side)).
  void part(const Part& part, unsigned skipFaces = 0);

 private:
  uint32_t vertex(const Vec3f& p, const Vec3f& normal, const Rgb8& color,
                  Surface surface, float shade);
  void triangle(uint32_t a, uint32_t b, uint32_t c, Surface surface);
  void box(const Part& part, unsigned skipFaces);
  void revolve(const Part& part);
  void sphere(const Part& part);

  TriangleMesh& mesh_;
  bool withUvs_;
  int object_ = -1;
  std::array<float, 3> tint_{1.0f, 1.0f, 1.0f};
};

/// {cos, sin} of 2*pi*k/n for n in {4, 8, 12, 16}, from square roots only.
std::array<float, 2> unitCircle(int k, int n);

/// Builds floors, ceilings, walls with doorways and skirting of `plan`
/// (leaving `holes` open in the floors) into `builder`.
void buildStructure(const FloorPlan& plan, const HouseStyle& style,
                    const HouseConfig& config,
                    const std::vector<Eigen::AlignedBox2f>& holes,
                    MeshBuilder& builder);

// ===========================================================================
// furniture
// ===========================================================================

/// A furniture model in its own frame: x across its front, centred (x in
/// [-width/2, width/2]); z from its back (0, against a wall) to its front
/// (depth); y up from the floor; metres. Parts stay inside that footprint so
/// placement tests on it are exact.
struct Model {
  std::string category;
  std::string color;
  float width = 0.0f;
  float depth = 0.0f;
  std::vector<Part> parts;
  bool hung = false;  ///< mounted on a wall above the floor
};

/// Neutral colours of model parts that do not carry the model's colour.
inline constexpr Rgb8 kDark{38, 38, 40};
inline constexpr Rgb8 kMetal{150, 150, 156};
inline constexpr Rgb8 kSteel{178, 182, 186};
inline constexpr Rgb8 kScreen{16, 17, 20};

/// `c` with every channel multiplied by `f`, rounded and clamped to a byte.
Rgb8 scaled(const Rgb8& c, float f);

/// Builds furniture models with random sizes and colours from `rng`;
/// heights are capped at `maxHeight` (below the ceiling).
class ModelBuilder {
 public:
  ModelBuilder(Rng& rng, float maxHeight) : rng_(rng), maxHeight_(maxHeight) {}

  /// One of `names`, uniformly.
  std::string chooseColor(const std::vector<const char*>& names);
  /// Surface of parts in colour `color`: wood grain for "wooden".
  static Surface finishOf(const std::string& color, Surface otherwise);

  // Each returns a model named by its category and colour (see
  // houseObjectCategories() and houseColorNames()).
  Model bed();         ///< frame, headboard, mattress, duvet, pillows
  Model nightstand();  ///< box with a drawer
  Model wardrobe();    ///< tall two-door cupboard
  Model dresser();     ///< chest of three drawers
  Model sofa(
      bool armchair);  ///< base, back, arms, cushions; one seat if armchair
  /// Top on four legs; `category` "table" or "coffee table".
  Model table(const char* category, float wLo, float wHi, float dLo, float dHi,
              float h, std::vector<const char*> colors);
  Model chair(const std::string& color);  ///< seat, back, four legs
  Model tv();                             ///< screen on a stand cabinet
  Model plant();     ///< pot with a bush, a cone tree or a tall crown
  Model lamp();      ///< floor lamp: base, pole, shade
  Model bookcase();  ///< tall open shelves full of books
  Model shelf();     ///< low open shelves
  Model desk();      ///< top, drawer pedestal, maybe a monitor
  Model cabinet();   ///< low cupboard with doors
  /// Kitchen base cabinet of width `w` with a worktop.
  Model counter(const std::string& color, const std::string& topName, float w);
  /// Free-standing kitchen counter, large enough to stand nodes on.
  Model island(const std::string& color, const std::string& topName);
  /// Kitchen sink in a counter, or a bathroom basin (pedestal or vanity).
  Model sink(bool kitchen, const std::string& color,
             const std::string& topName);
  Model stove();          ///< cooker with burners and an oven door
  Model fridge();         ///< tall fridge-freezer
  Model toilet();         ///< tank, bowl, seat
  Model bathtub();        ///< hollow tub
  Model washer();         ///< washing machine with a round door
  Model rug(bool small);  ///< bordered rug (a bath mat if small)
  Model picture();        ///< framed canvas hung at eye height
  Model mirror();         ///< framed glass hung on a wall
  /// A closed window with a `color` frame: sky-tinted glass, a cross bar
  /// and a sill. It never opens the wall, so the house stays sealed.
  Model window(float wallHeight, const std::string& color);
  Model piano();  ///< upright piano with keys

 private:
  Model start(const char* category, std::vector<const char*> colors);
  float height(float h) const;  // capped below the ceiling
  void box(Model& m, float x0, float y0, float z0, float x1, float y1, float z1,
           const Rgb8& color, Surface surface);
  void shape(Model& m, Shape s, float x0, float y0, float z0, float x1,
             float y1, float z1, const Rgb8& color,
             Surface surface = Surface::kPlain);
  // four square legs of side `size` from the floor to `top`, their
  // low-x, low-z corners at {x0, x1} x {z0, z1}
  void legs(Model& m, float x0, float x1, float z0, float z1, float size,
            float top, const Rgb8& color, Surface surface);
  // a row of books (or boxes) standing on a board at height y
  void books(Model& m, float x0, float x1, float y, float maxH, float d);
  // base cabinet, plinth and worktop shared by counters and kitchen sinks
  void counterBody(Model& m, const std::string& color,
                   const std::string& topName, float w, float d, float h,
                   bool doors);

  Rng& rng_;
  float maxHeight_;
};

/// A placed furniture landmark: its semantic record and world-frame parts.
struct PlacedObject {
  SemanticObject semantic;
  std::vector<Part> parts;
};

/// Resolution of the grid on which rooms are checked for navigability and
/// centred groups are placed, metres.
inline constexpr float kGridCell = 0.1f;

/// The horizontal (x, z) footprint of `box`.
inline Eigen::AlignedBox2f footprint(const Eigen::AlignedBox3f& box) {
  return Eigen::AlignedBox2f(Vec2f(box.min().x(), box.min().z()),
                             Vec2f(box.max().x(), box.max().z()));
}

/// Grid search over a room's `interior` (wall faces, (x, z) metres): with
/// the footprints `extra` and the `placed` objects (those an agent cannot
/// walk through block it) in the room, do all `doors` (points just inside
/// each doorway) connect, and does an agent that needs corridors of 0.6 m
/// get next to every placed object? Cells of kGridCell are free when their
/// centre keeps 0.3 m from walls and obstacles.
bool roomStaysNavigable(const Eigen::AlignedBox2f& interior,
                        const std::vector<Vec2f>& doors,
                        const std::vector<Eigen::AlignedBox3f>& placed,
                        const std::vector<Eigen::AlignedBox2f>& extra);

/// Furnishes every room of `plan` (object ids from 0 in placement order)
/// and, with probability config.floor_hole_probability, cuts one floor hole
/// away from doorways and furniture (appended to `holes`).
std::vector<PlacedObject> furnish(Rng& rng, const FloorPlan& plan,
                                  const HouseConfig& config,
                                  std::vector<Eigen::AlignedBox2f>& holes);

/// RGB of a colour name of houseColorNames().
Rgb8 namedColor(const std::string& name);

// ---------------------------------------------------------------------------
// template definitions
// ---------------------------------------------------------------------------

template <class ShadeFn>
void MeshBuilder::grid(const Vec3f& lo, const Vec3f& hi, int axis, int sign,
                       const std::vector<float>& cutsU,
                       const std::vector<float>& cutsV, const Rgb8& color,
                       Surface surface, ShadeFn shadeAt,
                       const std::vector<Eigen::AlignedBox2f>& holes) {
  // in-plane axes chosen so that (u, v, normal) is right-handed
  const int u = (axis + 1) % 3;
  const int v = (axis + 2) % 3;
  Vec3f normal = Vec3f::Zero();
  normal[axis] = static_cast<float>(sign);
  std::vector<float> us{lo[u]}, vs{lo[v]};
  for (float c : cutsU)
    if (c > lo[u] && c < hi[u]) us.push_back(c);
  for (float c : cutsV)
    if (c > lo[v] && c < hi[v]) vs.push_back(c);
  us.push_back(hi[u]);
  vs.push_back(hi[v]);
  std::sort(us.begin(), us.end());
  std::sort(vs.begin(), vs.end());
  us.erase(std::unique(us.begin(), us.end()), us.end());
  vs.erase(std::unique(vs.begin(), vs.end()), vs.end());
  for (size_t i = 0; i + 1 < us.size(); ++i) {
    for (size_t j = 0; j + 1 < vs.size(); ++j) {
      // holes are given in the plane's (u, v) coordinates
      const Vec2f mid(0.5f * (us[i] + us[i + 1]), 0.5f * (vs[j] + vs[j + 1]));
      bool open = false;
      for (const auto& hole : holes) open = open || hole.contains(mid);
      if (open) continue;
      std::array<Vec3f, 4> c;
      const float cu[4] = {us[i], us[i + 1], us[i + 1], us[i]};
      const float cv[4] = {vs[j], vs[j], vs[j + 1], vs[j + 1]};
      std::array<float, 4> shade;
      for (int k = 0; k < 4; ++k) {
        c[k] = lo;
        c[k][u] = cu[k];
        c[k][v] = cv[k];
        shade[k] = shadeAt(c[k]);
      }
      if (sign < 0) {
        std::swap(c[1], c[3]);
        std::swap(shade[1], shade[3]);
      }
      quad(c, normal, color, surface, shade);
    }
  }
}

}  // namespace vln::world::house
