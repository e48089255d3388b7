// Furniture of procedural houses: a catalogue of landmark models built from
// boxes, cylinders, cones and spheres, and their placement per room type
// (against walls, in the middle, hung on walls) with three guarantees:
//  - no object overlaps another object or a doorway's clear zone;
//  - every object lies inside its room;
//  - the room stays navigable: an agent needing corridors of
//    2 * kAgentClearance reaches every doorway and gets next to every object.

// Bit-identical houses on every machine: never fuse a*b+c into one FMA
// instruction, even in builds for CPUs that have it (-march=native). Must
// precede the includes so that inline header code is covered too.
#if defined(__clang__)
#pragma clang fp contract(off)
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>

#include "common/Check.h"
#include "sim/HouseBuilder.h"

namespace vln::sim::house {
namespace {

using Box2 = Eigen::AlignedBox2f;
using Box3 = Eigen::AlignedBox3f;

// Half the narrowest corridor kept free, metres (corridors >= 0.6 m).
constexpr float kAgentClearance = 0.3f;
// How close (beyond the clearance) a reachable spot must get to an object.
constexpr float kReachSlack = 0.25f;
// The same for objects hung on walls, which may hang above furniture.
constexpr float kHungReach = 1.5f;
constexpr float kGridCell = 0.1f;  // navigability grid resolution, metres
constexpr float kWallGap = 0.01f;  // furniture stands this far off walls
constexpr float kObjectGap = 0.01f;

// ===========================================================================
// colours
// ===========================================================================

const Rgb8 kDark{38, 38, 40};
const Rgb8 kMetal{150, 150, 156};
const Rgb8 kSteel{178, 182, 186};
const Rgb8 kLinen{238, 236, 228};
const Rgb8 kScreen{16, 17, 20};
const Rgb8 kGlass{196, 210, 220};
const Rgb8 kSoil{70, 50, 36};
const std::vector<Rgb8> kFoliage = {{62, 128, 58}, {48, 110, 52}, {84, 140, 64}};
const std::vector<Rgb8> kBookColors = {
    {150, 40, 40}, {40, 70, 140}, {40, 110, 60}, {200, 170, 60}, {120, 80, 50},
    {220, 220, 210}, {60, 60, 64}, {180, 100, 40}, {110, 60, 130}};

Rgb8 scaled(const Rgb8& c, float f) {
  auto s = [f](uint8_t v) {
    return static_cast<uint8_t>(std::clamp(static_cast<float>(v) * f + 0.5f, 0.0f, 255.0f));
  };
  return {s(c[0]), s(c[1]), s(c[2])};
}

// ===========================================================================
// models in a local frame
// ===========================================================================

// Local frame of a model: x across its front, centred (x in [-w/2, w/2]);
// z from its back (0, against a wall) to its front (depth); y up from the
// floor. Parts stay inside the footprint so placement tests stay exact.
struct Model {
  std::string category;
  std::string color;
  float width = 0.0f;
  float depth = 0.0f;
  std::vector<Part> parts;
  bool hung = false;  ///< mounted on a wall above the floor
};

class ModelBuilder {
 public:
  ModelBuilder(Rng& rng, float maxHeight) : rng_(rng), maxHeight_(maxHeight) {}

  // a colour name from `names` and the finish of the model's named parts
  std::string chooseColor(const std::vector<const char*>& names) {
    return names[rng_.intIn(0, static_cast<int>(names.size()) - 1)];
  }
  static Surface finishOf(const std::string& color, Surface otherwise) {
    return color == "wooden" ? Surface::kWood : otherwise;
  }

  Model bed() {
    Model m = start("bed", {"red", "blue", "green", "yellow", "white", "grey",
                            "purple", "pink", "orange"});
    const bool twin = rng_.chance(0.35f);
    const float w = twin ? rng_.uniform(0.9f, 1.0f) : rng_.uniform(1.4f, 1.8f);
    const float d = rng_.uniform(2.0f, 2.15f);
    const float head = height(rng_.uniform(0.95f, 1.15f));
    const std::string frameName = chooseColor({"wooden", "white", "black", "grey", "brown"});
    const Rgb8 frame = namedColor(frameName);
    const Surface frameFinish = finishOf(frameName, Surface::kPlain);
    const Rgb8 duvet = namedColor(m.color);
    m.width = w;
    m.depth = d;
    box(m, -w / 2, 0.0f, 0.06f, w / 2, 0.3f, d, frame, frameFinish);
    box(m, -w / 2, 0.0f, 0.0f, w / 2, head, 0.06f, frame, frameFinish);
    box(m, -w / 2 + 0.03f, 0.3f, 0.08f, w / 2 - 0.03f, 0.5f, d - 0.03f, kLinen, Surface::kFabric);
    box(m, -w / 2, 0.28f, d * 0.38f, w / 2, 0.56f, d, duvet, Surface::kFabric);
    const int pillows = twin ? 1 : 2;
    const float pw = (w - 0.16f) / static_cast<float>(pillows);
    for (int i = 0; i < pillows; ++i) {
      const float x0 = -w / 2 + 0.08f + static_cast<float>(i) * pw;
      box(m, x0 + 0.03f, 0.5f, 0.12f, x0 + pw - 0.03f, 0.62f, 0.5f,
          scaled(kLinen, 0.97f), Surface::kFabric);
    }
    return m;
  }

  Model nightstand() {
    Model m = start("nightstand", {"wooden", "white", "black", "brown", "grey"});
    const float w = rng_.uniform(0.42f, 0.52f), d = 0.4f, h = rng_.uniform(0.5f, 0.6f);
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(m.color);
    const Surface f = finishOf(m.color, Surface::kPlain);
    box(m, -w / 2, 0.0f, 0.0f, w / 2, h, d - 0.01f, c, f);
    box(m, -w / 2 + 0.03f, h * 0.55f, d - 0.01f, w / 2 - 0.03f, h * 0.56f, d, scaled(c, 0.6f), Surface::kPlain);
    box(m, -0.03f, h * 0.72f, d - 0.01f, 0.03f, h * 0.76f, d, kMetal, Surface::kPlain);
    return m;
  }

  Model wardrobe() {
    Model m = start("wardrobe", {"wooden", "white", "brown", "grey", "black"});
    const float w = rng_.uniform(1.0f, 1.6f), d = 0.6f, h = height(rng_.uniform(1.9f, 2.1f));
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(m.color);
    box(m, -w / 2, 0.0f, 0.0f, w / 2, h, d - 0.01f, c, finishOf(m.color, Surface::kPlain));
    box(m, -0.005f, 0.05f, d - 0.01f, 0.005f, h - 0.05f, d, scaled(c, 0.55f), Surface::kPlain);
    for (float x : {-0.06f, 0.04f})
      box(m, x, h * 0.45f, d - 0.01f, x + 0.02f, h * 0.6f, d, kMetal, Surface::kPlain);
    return m;
  }

  Model dresser() {
    Model m = start("dresser", {"wooden", "white", "brown", "black", "grey", "blue"});
    const float w = rng_.uniform(1.0f, 1.4f), d = 0.5f, h = rng_.uniform(0.8f, 0.92f);
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(m.color);
    box(m, -w / 2, 0.0f, 0.0f, w / 2, h, d - 0.01f, c, finishOf(m.color, Surface::kPlain));
    for (int i = 1; i <= 3; ++i) {
      const float y = h * static_cast<float>(i) / 4.0f;
      box(m, -w / 2 + 0.03f, y - 0.005f, d - 0.01f, w / 2 - 0.03f, y + 0.005f, d, scaled(c, 0.6f), Surface::kPlain);
      box(m, -0.05f, y + 0.06f, d - 0.01f, 0.05f, y + 0.08f, d, kMetal, Surface::kPlain);
    }
    return m;
  }

  Model sofa(bool armchair) {
    Model m = start(armchair ? "armchair" : "sofa",
                    {"red", "blue", "green", "grey", "brown", "black", "yellow",
                     "orange", "purple", "white", "pink"});
    const float w = armchair ? rng_.uniform(0.8f, 0.95f) : rng_.uniform(1.8f, 2.4f);
    const float d = rng_.uniform(0.85f, 0.95f), h = rng_.uniform(0.8f, 0.9f);
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(m.color);
    const Surface f = Surface::kFabric;
    const float arm = 0.16f;
    for (float x : {-w / 2 + 0.03f, w / 2 - 0.08f})
      for (float z : {0.03f, d - 0.08f})
        box(m, x, 0.0f, z, x + 0.05f, 0.1f, z + 0.05f, kDark, Surface::kPlain);
    box(m, -w / 2, 0.1f, 0.0f, w / 2, 0.42f, d, scaled(c, 0.9f), f);
    box(m, -w / 2, 0.42f, 0.0f, w / 2, h, 0.22f, c, f);
    box(m, -w / 2, 0.42f, 0.0f, -w / 2 + arm, 0.64f, d, c, f);
    box(m, w / 2 - arm, 0.42f, 0.0f, w / 2, 0.64f, d, c, f);
    const int cushions = armchair ? 1 : (w > 2.1f ? 3 : 2);
    const float span = w - 2 * arm;
    for (int i = 0; i < cushions; ++i) {
      const float x0 = -w / 2 + arm + span * static_cast<float>(i) / cushions;
      const float x1 = -w / 2 + arm + span * static_cast<float>(i + 1) / cushions;
      box(m, x0 + 0.01f, 0.42f, 0.22f, x1 - 0.01f, 0.54f, d - 0.02f, scaled(c, 1.08f), f);
    }
    return m;
  }

  Model table(const char* category, float wLo, float wHi, float dLo, float dHi,
              float h, std::vector<const char*> colors) {
    Model m = start(category, colors);
    const float w = rng_.uniform(wLo, wHi), d = rng_.uniform(dLo, dHi);
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(m.color);
    const Surface f = finishOf(m.color, Surface::kPlain);
    box(m, -w / 2, h - 0.04f, 0.0f, w / 2, h, d, c, f);
    const float leg = 0.06f, inset = 0.05f;
    for (float x : {-w / 2 + inset, w / 2 - inset - leg})
      for (float z : {inset, d - inset - leg})
        box(m, x, 0.0f, z, x + leg, h - 0.04f, z + leg, scaled(c, 0.85f), f);
    return m;
  }

  Model chair(const std::string& color) {
    Model m;
    m.category = "chair";
    m.color = color;
    const float w = 0.44f, d = 0.46f;
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(color);
    const Surface f = finishOf(color, Surface::kPlain);
    box(m, -w / 2, 0.42f, 0.0f, w / 2, 0.46f, d, c, f);
    box(m, -w / 2, 0.46f, 0.0f, w / 2, 0.9f, 0.04f, c, f);
    const float leg = 0.04f;
    for (float x : {-w / 2, w / 2 - leg})
      for (float z : {0.0f, d - leg})
        box(m, x, 0.0f, z, x + leg, 0.42f, z + leg, scaled(c, 0.85f), f);
    return m;
  }

  Model tv() {
    Model m = start("tv", {"black", "black", "grey", "white"});
    const float w = rng_.uniform(1.2f, 1.6f), d = 0.42f, standH = rng_.uniform(0.42f, 0.55f);
    m.width = w;
    m.depth = d;
    const std::string standName = chooseColor({"wooden", "white", "black", "grey"});
    const Rgb8 stand = namedColor(standName);
    box(m, -w / 2, 0.0f, 0.0f, w / 2, standH, d, stand, finishOf(standName, Surface::kPlain));
    const float sw = std::min(w - 0.1f, rng_.uniform(0.9f, 1.3f));
    const float sh = sw * 0.58f;
    const Rgb8 bezel = namedColor(m.color);
    box(m, -0.12f, standH, 0.1f, 0.12f, standH + 0.02f, 0.28f, bezel, Surface::kPlain);
    box(m, -0.03f, standH + 0.02f, 0.16f, 0.03f, standH + 0.1f, 0.2f, bezel, Surface::kPlain);
    box(m, -sw / 2, standH + 0.1f, 0.15f, sw / 2, standH + 0.1f + sh, 0.2f, bezel, Surface::kPlain);
    box(m, -sw / 2 + 0.02f, standH + 0.12f, 0.2f, sw / 2 - 0.02f, standH + 0.08f + sh, 0.205f, kScreen, Surface::kPlain);
    return m;
  }

  Model plant() {
    Model m;
    m.category = "plant";
    m.color = "green";
    const float potR = rng_.uniform(0.13f, 0.2f), potH = rng_.uniform(0.25f, 0.4f);
    const int style = rng_.intIn(0, 2);
    const float crown = style == 1 ? potR * 2.2f : rng_.uniform(0.45f, 0.7f);
    const float w = std::max(2 * potR, crown);
    m.width = w;
    m.depth = w;
    const std::vector<Rgb8> pots = {{236, 236, 232}, {128, 128, 128}, {182, 92, 60}, {40, 40, 42}, {60, 90, 160}};
    const Rgb8 pot = pots[rng_.intIn(0, static_cast<int>(pots.size()) - 1)];
    const float cz = w / 2;
    shape(m, Shape::kCylinderY, -potR, 0.0f, cz - potR, potR, potH, cz + potR, pot);
    shape(m, Shape::kCylinderY, -potR * 0.85f, potH, cz - potR * 0.85f, potR * 0.85f, potH + 0.01f, cz + potR * 0.85f, kSoil);
    const Rgb8 leaf = kFoliage[rng_.intIn(0, static_cast<int>(kFoliage.size()) - 1)];
    if (style == 0) {
      // bushy: a crown of two spheres
      const float top = potH + crown;
      shape(m, Shape::kSphere, -crown / 2, potH, cz - crown / 2, crown / 2, top, cz + crown / 2, leaf);
      shape(m, Shape::kSphere, -crown / 3, top - crown * 0.45f, cz - crown / 3, crown / 3, top + crown * 0.25f, cz + crown / 3, scaled(leaf, 1.12f));
    } else if (style == 1) {
      // a small tree: a cone of foliage
      const float h = height(potH + rng_.uniform(0.9f, 1.3f));
      shape(m, Shape::kConeY, -crown / 2, potH + 0.05f, cz - crown / 2, crown / 2, h, cz + crown / 2, leaf);
    } else {
      // a tall plant: trunk and a high crown
      const float h = height(potH + rng_.uniform(1.0f, 1.4f));
      shape(m, Shape::kCylinderY, -0.025f, potH, cz - 0.025f, 0.025f, h - crown * 0.5f, cz + 0.025f, {96, 70, 48});
      shape(m, Shape::kSphere, -crown / 2, h - crown, cz - crown / 2, crown / 2, h, cz + crown / 2, leaf);
    }
    return m;
  }

  Model lamp() {
    Model m = start("lamp", {"white", "yellow", "orange", "red", "blue", "green", "black", "grey"});
    const float r = rng_.uniform(0.18f, 0.25f), pole = rng_.uniform(1.25f, 1.45f);
    m.width = 2 * r;
    m.depth = 2 * r;
    const float cz = r;
    shape(m, Shape::kCylinderY, -0.14f, 0.0f, cz - 0.14f, 0.14f, 0.03f, cz + 0.14f, kDark);
    shape(m, Shape::kCylinderY, -0.015f, 0.03f, cz - 0.015f, 0.015f, pole, cz + 0.015f, kMetal);
    shape(m, Shape::kFrustumY, -r, pole - 0.08f, cz - r, r, height(pole + 0.25f), cz + r, namedColor(m.color));
    return m;
  }

  Model bookcase() {
    Model m = start("bookcase", {"wooden", "white", "black", "brown"});
    const float w = rng_.uniform(0.8f, 1.2f), d = rng_.uniform(0.32f, 0.38f);
    const float h = height(rng_.uniform(1.8f, 2.0f));
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(m.color);
    const Surface f = finishOf(m.color, Surface::kPlain);
    box(m, -w / 2, 0.0f, 0.0f, -w / 2 + 0.02f, h, d, c, f);
    box(m, w / 2 - 0.02f, 0.0f, 0.0f, w / 2, h, d, c, f);
    box(m, -w / 2 + 0.02f, h - 0.02f, 0.0f, w / 2 - 0.02f, h, d, c, f);
    box(m, -w / 2 + 0.02f, 0.0f, 0.0f, w / 2 - 0.02f, 0.06f, d, c, f);
    box(m, -w / 2 + 0.02f, 0.06f, 0.0f, w / 2 - 0.02f, h - 0.02f, 0.01f, scaled(c, 0.8f), f);
    const int shelves = rng_.intIn(4, 5);
    const float step = (h - 0.08f) / static_cast<float>(shelves);
    for (int s = 0; s < shelves; ++s) {
      const float y = 0.06f + step * static_cast<float>(s);
      if (s > 0) box(m, -w / 2 + 0.02f, y - 0.02f, 0.01f, w / 2 - 0.02f, y, d, c, f);
      books(m, -w / 2 + 0.03f, w / 2 - 0.03f, y, std::min(step - 0.05f, 0.3f), d);
    }
    return m;
  }

  Model shelf() {
    Model m = start("shelf", {"wooden", "white", "black", "grey"});
    const float w = rng_.uniform(0.8f, 1.4f), d = rng_.uniform(0.3f, 0.36f), h = rng_.uniform(0.8f, 1.1f);
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(m.color);
    const Surface f = finishOf(m.color, Surface::kPlain);
    box(m, -w / 2, 0.0f, 0.0f, -w / 2 + 0.025f, h, d, c, f);
    box(m, w / 2 - 0.025f, 0.0f, 0.0f, w / 2, h, d, c, f);
    const int boards = h > 0.95f ? 3 : 2;
    for (int b = 0; b <= boards; ++b) {
      const float y = b == 0 ? 0.04f : h * static_cast<float>(b) / boards;
      box(m, -w / 2 + 0.025f, y - 0.025f, 0.0f, w / 2 - 0.025f, y, d, c, f);
      if (b < boards) books(m, -w / 2 + 0.04f, w / 2 - 0.04f, y, h / boards - 0.06f, d);
    }
    return m;
  }

  Model desk() {
    Model m = start("desk", {"wooden", "white", "black", "grey"});
    const float w = rng_.uniform(1.2f, 1.6f), d = rng_.uniform(0.6f, 0.7f), h = 0.75f;
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(m.color);
    const Surface f = finishOf(m.color, Surface::kPlain);
    box(m, -w / 2, h - 0.03f, 0.0f, w / 2, h, d, c, f);
    box(m, -w / 2, 0.0f, 0.0f, -w / 2 + 0.42f, h - 0.03f, d - 0.02f, scaled(c, 0.92f), f);
    box(m, w / 2 - 0.03f, 0.0f, 0.0f, w / 2, h - 0.03f, d - 0.02f, scaled(c, 0.92f), f);
    for (int i = 1; i <= 2; ++i) {
      const float y = (h - 0.03f) * static_cast<float>(i) / 3.0f;
      box(m, -w / 2 + 0.03f, y - 0.004f, d - 0.02f, -w / 2 + 0.39f, y + 0.004f, d - 0.01f, scaled(c, 0.6f), Surface::kPlain);
    }
    if (rng_.chance(0.6f)) {
      // a monitor on the desk
      const float mw = rng_.uniform(0.5f, 0.65f);
      box(m, -0.1f, h, 0.08f, 0.1f, h + 0.015f, 0.22f, kDark, Surface::kPlain);
      box(m, -0.02f, h + 0.015f, 0.12f, 0.02f, h + 0.12f, 0.16f, kDark, Surface::kPlain);
      box(m, -mw / 2, h + 0.12f, 0.1f, mw / 2, h + 0.12f + mw * 0.6f, 0.13f, kDark, Surface::kPlain);
      box(m, -mw / 2 + 0.015f, h + 0.135f, 0.13f, mw / 2 - 0.015f, h + 0.105f + mw * 0.6f, 0.133f, kScreen, Surface::kPlain);
    }
    return m;
  }

  Model cabinet() {
    Model m = start("cabinet", {"wooden", "white", "grey", "blue", "green", "black"});
    const float w = rng_.uniform(0.6f, 1.2f), d = 0.45f, h = rng_.uniform(0.8f, 1.2f);
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(m.color);
    box(m, -w / 2, 0.0f, 0.0f, w / 2, 0.08f, d - 0.04f, kDark, Surface::kPlain);
    box(m, -w / 2, 0.08f, 0.0f, w / 2, h, d - 0.01f, c, finishOf(m.color, Surface::kPlain));
    const int doors = w > 0.8f ? 2 : 1;
    if (doors == 2)
      box(m, -0.004f, 0.1f, d - 0.01f, 0.004f, h - 0.02f, d, scaled(c, 0.55f), Surface::kPlain);
    for (int i = 0; i < doors; ++i) {
      const float x = doors == 1 ? w / 2 - 0.08f : (i == 0 ? -0.06f : 0.04f);
      box(m, x, h - 0.25f, d - 0.01f, x + 0.02f, h - 0.1f, d, kMetal, Surface::kPlain);
    }
    return m;
  }

  Model counter(const std::string& color, const std::string& topName, float w) {
    Model m;
    m.category = "counter";
    m.color = color;
    const float d = 0.62f, h = 0.9f;
    m.width = w;
    m.depth = d;
    counterBody(m, color, topName, w, d, h, /*doors=*/true);
    return m;
  }

  Model island(const std::string& color, const std::string& topName) {
    Model m;
    m.category = "kitchen island";
    m.color = color;
    const float w = rng_.uniform(1.5f, 2.2f), d = rng_.uniform(0.9f, 1.0f), h = 0.92f;
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(color);
    box(m, -w / 2 + 0.05f, 0.0f, 0.05f, w / 2 - 0.05f, h - 0.04f, d - 0.05f, c, finishOf(color, Surface::kPlain));
    box(m, -w / 2, h - 0.04f, 0.0f, w / 2, h, d, namedColor(topName), finishOf(topName, Surface::kPlain));
    return m;
  }

  Model sink(bool kitchen, const std::string& color, const std::string& topName) {
    Model m;
    m.category = "sink";
    if (kitchen) {
      m.color = "grey";
      const float w = rng_.uniform(0.8f, 1.0f), d = 0.62f, h = 0.9f;
      m.width = w;
      m.depth = d;
      counterBody(m, color, topName, w, d, h, /*doors=*/true);
      box(m, -0.3f, h, 0.12f, 0.3f, h + 0.012f, 0.52f, kSteel, Surface::kPlain);
      box(m, -0.26f, h + 0.012f, 0.16f, 0.26f, h + 0.014f, 0.48f, scaled(kSteel, 0.7f), Surface::kPlain);
      shape(m, Shape::kCylinderY, -0.02f, h, 0.04f, 0.02f, h + 0.3f, 0.08f, kSteel);
    } else {
      m.color = "white";
      const float w = rng_.uniform(0.55f, 0.8f), d = 0.48f;
      m.width = w;
      m.depth = d;
      const Rgb8 white = namedColor("white");
      if (rng_.chance(0.5f)) {
        // pedestal sink
        shape(m, Shape::kCylinderY, -0.09f, 0.0f, 0.12f, 0.09f, 0.7f, 0.3f, white);
        box(m, -w / 2, 0.7f, 0.0f, w / 2, 0.86f, d, white, Surface::kPlain);
      } else {
        // vanity cabinet with a basin top
        const Rgb8 cab = namedColor(chooseColor({"wooden", "white", "grey"}));
        box(m, -w / 2, 0.0f, 0.0f, w / 2, 0.8f, d - 0.02f, cab, Surface::kPlain);
        box(m, -w / 2, 0.8f, 0.0f, w / 2, 0.86f, d, white, Surface::kPlain);
      }
      box(m, -w / 2 + 0.08f, 0.86f, 0.12f, w / 2 - 0.08f, 0.865f, d - 0.06f, scaled(white, 0.85f), Surface::kPlain);
      shape(m, Shape::kCylinderY, -0.015f, 0.86f, 0.04f, 0.015f, 1.05f, 0.07f, kSteel);
    }
    return m;
  }

  Model stove() {
    Model m = start("stove", {"white", "black", "grey"});
    const float w = 0.6f, d = 0.62f, h = 0.9f;
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(m.color);
    box(m, -w / 2, 0.0f, 0.0f, w / 2, h - 0.02f, d - 0.02f, c, Surface::kPlain);
    box(m, -w / 2, h - 0.02f, 0.0f, w / 2, h, d - 0.02f, kDark, Surface::kPlain);
    for (float x : {-0.14f, 0.14f})
      for (float z : {0.16f, 0.42f})
        shape(m, Shape::kCylinderY, x - 0.085f, h, z - 0.085f, x + 0.085f, h + 0.01f, z + 0.085f, {60, 60, 62});
    box(m, -w / 2 + 0.06f, 0.15f, d - 0.02f, w / 2 - 0.06f, 0.6f, d - 0.01f, kScreen, Surface::kPlain);
    shape(m, Shape::kCylinderX, -w / 2 + 0.08f, 0.66f, d - 0.02f, w / 2 - 0.08f, 0.68f, d, kSteel);
    box(m, -w / 2 + 0.03f, 0.74f, d - 0.02f, w / 2 - 0.03f, 0.84f, d - 0.01f, scaled(c, 0.7f), Surface::kPlain);
    return m;
  }

  Model fridge() {
    Model m = start("fridge", {"white", "white", "grey", "black", "red"});
    const float w = rng_.uniform(0.6f, 0.8f), d = 0.68f, h = height(rng_.uniform(1.7f, 1.9f));
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(m.color);
    box(m, -w / 2, 0.0f, 0.0f, w / 2, h, d - 0.03f, c, Surface::kPlain);
    box(m, -w / 2 + 0.01f, h * 0.62f - 0.005f, d - 0.03f, w / 2 - 0.01f, h * 0.62f + 0.005f, d - 0.025f, scaled(c, 0.6f), Surface::kPlain);
    box(m, w / 2 - 0.07f, h * 0.35f, d - 0.025f, w / 2 - 0.05f, h * 0.58f, d, kSteel, Surface::kPlain);
    box(m, w / 2 - 0.07f, h * 0.66f, d - 0.025f, w / 2 - 0.05f, h * 0.8f, d, kSteel, Surface::kPlain);
    return m;
  }

  Model toilet() {
    Model m = start("toilet", {"white", "white", "white", "black"});
    const float w = 0.4f, d = 0.7f;
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(m.color);
    box(m, -0.19f, 0.4f, 0.0f, 0.19f, 0.8f, 0.18f, c, Surface::kPlain);
    box(m, -0.11f, 0.0f, 0.18f, 0.11f, 0.3f, 0.55f, c, Surface::kPlain);
    shape(m, Shape::kCylinderY, -0.19f, 0.25f, 0.2f, 0.19f, 0.4f, 0.7f, c);
    shape(m, Shape::kCylinderY, -0.18f, 0.4f, 0.21f, 0.18f, 0.425f, 0.69f, scaled(c, 0.94f));
    return m;
  }

  Model bathtub() {
    Model m = start("bathtub", {"white", "white", "white", "grey"});
    const float w = rng_.uniform(1.5f, 1.7f), d = rng_.uniform(0.7f, 0.8f), h = 0.55f, t = 0.07f;
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(m.color);
    box(m, -w / 2, 0.0f, 0.0f, w / 2, h, t, c, Surface::kPlain);
    box(m, -w / 2, 0.0f, d - t, w / 2, h, d, c, Surface::kPlain);
    box(m, -w / 2, 0.0f, t, -w / 2 + t, h, d - t, c, Surface::kPlain);
    box(m, w / 2 - t, 0.0f, t, w / 2, h, d - t, c, Surface::kPlain);
    box(m, -w / 2 + t, 0.0f, t, w / 2 - t, 0.12f, d - t, scaled(c, 0.9f), Surface::kPlain);
    shape(m, Shape::kCylinderY, -w / 2 + 0.12f, h, 0.02f, -w / 2 + 0.16f, h + 0.2f, 0.06f, kSteel);
    return m;
  }

  Model washer() {
    Model m = start("washing machine", {"white", "white", "grey"});
    const float w = 0.6f, d = 0.6f, h = 0.85f;
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(m.color);
    box(m, -w / 2, 0.0f, 0.0f, w / 2, h, d - 0.03f, c, Surface::kPlain);
    shape(m, Shape::kCylinderZ, -0.2f, 0.22f, d - 0.03f, 0.2f, 0.62f, d - 0.01f, kMetal);
    shape(m, Shape::kCylinderZ, -0.14f, 0.28f, d - 0.01f, 0.14f, 0.56f, d, kScreen);
    box(m, -w / 2 + 0.03f, h - 0.12f, d - 0.03f, w / 2 - 0.03f, h - 0.03f, d - 0.02f, scaled(c, 0.75f), Surface::kPlain);
    return m;
  }

  Model rug(bool small) {
    Model m = start("rug", {"red", "blue", "green", "grey", "brown", "orange",
                            "purple", "pink", "yellow"});
    const float w = small ? rng_.uniform(0.6f, 0.9f) : rng_.uniform(1.2f, 2.4f);
    const float d = small ? rng_.uniform(0.4f, 0.6f) : rng_.uniform(0.8f, std::min(1.7f, w));
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(m.color);
    const float border = std::min(0.08f, 0.1f * d);
    box(m, -w / 2, 0.0f, 0.0f, w / 2, 0.01f, d, scaled(c, 0.7f), Surface::kCarpet);
    box(m, -w / 2 + border, 0.01f, border, w / 2 - border, 0.012f, d - border, c, Surface::kCarpet);
    return m;
  }

  Model picture() {
    Model m = start("picture", {"red", "blue", "green", "yellow", "orange", "purple", "pink"});
    m.hung = true;
    const float w = rng_.uniform(0.4f, 1.0f), h = rng_.uniform(0.3f, std::min(0.8f, w * 1.2f));
    const float center = rng_.uniform(1.45f, 1.6f);
    const float y0 = center - h / 2, y1 = center + h / 2;
    m.width = w;
    m.depth = 0.04f;
    const Rgb8 frame = namedColor(chooseColor({"black", "white", "grey"}));
    const float f = 0.035f;
    box(m, -w / 2, y0, 0.0f, w / 2, y1, 0.035f, frame, Surface::kPlain);
    box(m, -w / 2 + f, y0 + f, 0.035f, w / 2 - f, y1 - f, 0.037f, namedColor(m.color), Surface::kPlain);
    // a few small shapes of other colours; the named colour stays dominant
    const int marks = rng_.intIn(1, 3);
    for (int i = 0; i < marks; ++i) {
      const float mw = (w - 2 * f) * rng_.uniform(0.1f, 0.25f);
      const float mh = (h - 2 * f) * rng_.uniform(0.1f, 0.3f);
      const float mx = rng_.uniform(-w / 2 + f, w / 2 - f - mw);
      const float my = rng_.uniform(y0 + f, y1 - f - mh);
      const Rgb8 mark = kBookColors[rng_.intIn(0, static_cast<int>(kBookColors.size()) - 1)];
      box(m, mx, my, 0.037f, mx + mw, my + mh, 0.04f, mark, Surface::kPlain);
    }
    return m;
  }

  Model mirror() {
    Model m = start("mirror", {"white", "black", "wooden", "grey"});
    m.hung = true;
    const float w = rng_.uniform(0.5f, 0.8f), h = rng_.uniform(0.7f, 0.95f);
    const float y0 = rng_.uniform(1.1f, 1.2f);
    m.width = w;
    m.depth = 0.035f;
    box(m, -w / 2, y0, 0.0f, w / 2, y0 + h, 0.03f, namedColor(m.color), finishOf(m.color, Surface::kPlain));
    box(m, -w / 2 + 0.04f, y0 + 0.04f, 0.03f, w / 2 - 0.04f, y0 + h - 0.04f, 0.035f, kGlass, Surface::kPlain);
    return m;
  }

  // A closed window: frame, sky-tinted glass, a cross bar and a sill. It
  // never opens the wall, so the house stays sealed.
  Model window(float wallHeight) {
    Model m = start("window", {"white", "white", "black", "wooden", "grey"});
    m.hung = true;
    const float w = rng_.uniform(0.8f, 1.5f);
    const float y0 = rng_.uniform(0.9f, 1.0f);
    const float y1 = std::min(wallHeight - 0.3f, rng_.uniform(2.0f, 2.2f));
    m.width = w;
    m.depth = 0.1f;
    const Rgb8 frame = namedColor(m.color);
    const Surface f = finishOf(m.color, Surface::kPlain);
    const float b = 0.06f;
    box(m, -w / 2, y0, 0.0f, w / 2, y1, 0.03f, {178, 206, 232}, Surface::kPlain);
    box(m, -w / 2, y0, 0.03f, -w / 2 + b, y1, 0.06f, frame, f);
    box(m, w / 2 - b, y0, 0.03f, w / 2, y1, 0.06f, frame, f);
    box(m, -w / 2 + b, y1 - b, 0.03f, w / 2 - b, y1, 0.06f, frame, f);
    box(m, -w / 2 + b, y0, 0.03f, w / 2 - b, y0 + b, 0.06f, frame, f);
    box(m, -0.02f, y0 + b, 0.03f, 0.02f, y1 - b, 0.05f, frame, f);
    const float mid = y0 + 0.6f * (y1 - y0);
    box(m, -w / 2 + b, mid - 0.02f, 0.03f, w / 2 - b, mid + 0.02f, 0.05f, frame, f);
    box(m, -w / 2 - 0.0f, y0 - 0.03f, 0.0f, w / 2, y0, 0.1f, frame, f);
    return m;
  }

  Model piano() {
    Model m = start("piano", {"black", "black", "brown", "white"});
    const float w = rng_.uniform(1.45f, 1.55f), d = 0.62f, h = rng_.uniform(1.15f, 1.25f);
    m.width = w;
    m.depth = d;
    const Rgb8 c = namedColor(m.color);
    box(m, -w / 2, 0.0f, 0.0f, w / 2, h, 0.36f, c, Surface::kPlain);
    box(m, -w / 2, 0.68f, 0.36f, w / 2, 0.72f, 0.58f, c, Surface::kPlain);
    box(m, -w / 2 + 0.05f, 0.72f, 0.38f, w / 2 - 0.05f, 0.75f, 0.58f, {244, 244, 238}, Surface::kPlain);
    box(m, -w / 2 + 0.05f, 0.75f, 0.38f, w / 2 - 0.05f, 0.765f, 0.46f, kScreen, Surface::kPlain);
    for (float x : {-w / 2 + 0.02f, w / 2 - 0.07f})
      box(m, x, 0.0f, 0.52f, x + 0.05f, 0.68f, d, c, Surface::kPlain);
    return m;
  }

 private:
  Model start(const char* category, std::vector<const char*> colors) {
    Model m;
    m.category = category;
    m.color = chooseColor(colors);
    return m;
  }

  float height(float h) const { return std::min(h, maxHeight_); }

  void box(Model& m, float x0, float y0, float z0, float x1, float y1, float z1,
           const Rgb8& color, Surface surface) {
    shape(m, Shape::kBox, x0, y0, z0, x1, y1, z1, color, surface);
  }
  void shape(Model& m, Shape s, float x0, float y0, float z0, float x1, float y1,
             float z1, const Rgb8& color, Surface surface = Surface::kPlain) {
    Part p;
    p.shape = s;
    p.box = Box3(Vec3f(x0, std::min(y0, maxHeight_), z0), Vec3f(x1, std::min(y1, maxHeight_), z1));
    p.color = color;
    p.surface = surface;
    m.parts.push_back(p);
  }

  // a row of books (or boxes) standing on a board at height y
  void books(Model& m, float x0, float x1, float y, float maxH, float d) {
    float x = x0 + rng_.uniform(0.0f, 0.08f);
    int count = 0;
    while (x < x1 - 0.06f && count < 8 && maxH > 0.1f) {
      const float bw = rng_.uniform(0.025f, 0.06f);
      const float bh = rng_.uniform(0.6f, 0.95f) * maxH;
      const Rgb8 color = kBookColors[rng_.intIn(0, static_cast<int>(kBookColors.size()) - 1)];
      box(m, x, y, 0.03f, std::min(x + bw, x1), y + bh, d - rng_.uniform(0.03f, 0.08f), color, Surface::kPlain);
      x += bw + (rng_.chance(0.15f) ? rng_.uniform(0.05f, 0.2f) : 0.002f);
      ++count;
    }
  }

  void counterBody(Model& m, const std::string& color, const std::string& topName,
                   float w, float d, float h, bool doors) {
    const Rgb8 c = namedColor(color);
    box(m, -w / 2, 0.0f, 0.0f, w / 2, 0.1f, d - 0.08f, kDark, Surface::kPlain);
    box(m, -w / 2, 0.1f, 0.0f, w / 2, h - 0.04f, d - 0.04f, c, finishOf(color, Surface::kPlain));
    box(m, -w / 2, h - 0.04f, 0.0f, w / 2, h, d, namedColor(topName), finishOf(topName, Surface::kPlain));
    if (!doors) return;
    const int count = std::max(1, static_cast<int>(w / 0.5f));
    for (int i = 1; i < count; ++i) {
      const float x = -w / 2 + w * static_cast<float>(i) / count;
      box(m, x - 0.003f, 0.12f, d - 0.04f, x + 0.003f, h - 0.06f, d - 0.035f, scaled(c, 0.55f), Surface::kPlain);
    }
    for (int i = 0; i < count; ++i) {
      const float x = -w / 2 + w * (static_cast<float>(i) + 0.5f) / count;
      box(m, x - 0.06f, h - 0.16f, d - 0.04f, x + 0.06f, h - 0.14f, d - 0.035f, kMetal, Surface::kPlain);
    }
  }

  Rng& rng_;
  float maxHeight_;
};

// ===========================================================================
// placement
// ===========================================================================

// A model placed relative to its group: offset of its local origin and an
// extra quarter-turn.
struct Member {
  Model model;
  float ox = 0.0f, oz = 0.0f;
  int turn = 0;
};
using Group = std::vector<Member>;
// accepts a wall placement: (side, near end, far end along the wall)
using SpanFilter = std::function<bool(int, float, float)>;

// local (x, z) rotated by `turn` quarter turns about +y
Vec2f rotate(float x, float z, int turn) {
  switch (turn & 3) {
    case 0: return {x, z};
    case 1: return {z, -x};
    case 2: return {-x, -z};
    default: return {-z, x};
  }
}

Shape rotateShape(Shape shape, int turn) {
  if ((turn & 1) == 0) return shape;
  if (shape == Shape::kCylinderX) return Shape::kCylinderZ;
  if (shape == Shape::kCylinderZ) return Shape::kCylinderX;
  return shape;
}

// A member's parts in the world for group anchor (ax, az) and turn.
std::vector<Part> worldParts(const Member& member, float ax, float az, int turn) {
  const Vec2f origin = Vec2f(ax, az) + rotate(member.ox, member.oz, turn);
  const int total = turn + member.turn;
  std::vector<Part> out;
  for (const Part& p : member.model.parts) {
    const Vec2f a = rotate(p.box.min().x(), p.box.min().z(), total);
    const Vec2f b = rotate(p.box.max().x(), p.box.max().z(), total);
    Part q = p;
    q.shape = rotateShape(p.shape, total);
    q.box = Box3(Vec3f(origin.x() + std::min(a.x(), b.x()), p.box.min().y(),
                       origin.y() + std::min(a.y(), b.y())),
                 Vec3f(origin.x() + std::max(a.x(), b.x()), p.box.max().y(),
                       origin.y() + std::max(a.y(), b.y())));
    out.push_back(q);
  }
  return out;
}

Box3 boundsOf(const std::vector<Part>& parts) {
  Box3 box;
  for (const Part& p : parts) box.extend(p.box);
  return box;
}

Box2 footprint(const Box3& box) {
  return Box2(Vec2f(box.min().x(), box.min().z()), Vec2f(box.max().x(), box.max().z()));
}

// strict overlap with a tolerance: touching boxes do not overlap
bool overlaps(const Box2& a, const Box2& b, float gap) {
  return a.min().x() < b.max().x() + gap && b.min().x() < a.max().x() + gap &&
         a.min().y() < b.max().y() + gap && b.min().y() < a.max().y() + gap;
}
bool overlaps(const Box3& a, const Box3& b, float gap) {
  for (int i = 0; i < 3; ++i)
    if (!(a.min()[i] < b.max()[i] + gap && b.min()[i] < a.max()[i] + gap)) return false;
  return true;
}

float distanceToBox(const Vec2f& p, const Box2& box) {
  const float dx = std::max({box.min().x() - p.x(), 0.0f, p.x() - box.max().x()});
  const float dz = std::max({box.min().y() - p.y(), 0.0f, p.y() - box.max().y()});
  return std::sqrt(dx * dx + dz * dz);
}

// objects an agent cannot walk through (rugs are walked on)
bool blocksWalking(const Box3& box) { return box.max().y() > 0.05f && box.min().y() < 1.5f; }

float cmToM(int value) { return static_cast<float>(value) / 100.0f; }

// The state of one room while it is being furnished.
class RoomFurnisher {
 public:
  RoomFurnisher(Rng& rng, const FloorPlan& plan, int room, const HouseConfig& config,
                std::vector<PlacedObject>& objects)
      : rng_(rng), plan_(plan), room_(room), config_(config), objects_(objects),
        models_(rng, config.wall_height - 0.1f) {
    const RectCm& cell = plan.rooms[room].cell;
    const float h = 0.5f * config.wall_thickness;
    interior_ = Box2(Vec2f(cmToM(cell.x0) + h, cmToM(cell.z0) + h),
                     Vec2f(cmToM(cell.x1) - h, cmToM(cell.z1) - h));
    for (const PlanDoor& door : plan.doors) {
      if (door.room_a != room && door.room_b != room) continue;
      const Doorway d = toDoorway(door);
      zones_.push_back(doorwayClearZone(d));
      // a point half a metre into this room in front of the opening
      const Vec2f center(d.center.x(), d.center.z());
      const Vec2f normal(d.normal.x(), d.normal.z());
      const Vec2f mid = interior_.center();
      const float side = (mid - center).dot(normal) >= 0.0f ? 1.0f : -1.0f;
      seeds_.push_back(center + side * (0.5f * kDoorwayClearDepth) * normal);
    }
    if (seeds_.empty()) seeds_.push_back(interior_.center());
    for (const PlacedObject& o : objects)
      if (o.semantic.room == room) placed_.push_back(o.semantic.bounds);
  }

  // ---- recipes ------------------------------------------------------------
  void furnish(const std::string& type) {
    const float density = config_.furniture_density;
    if (density <= 0.0f) return;
    auto maybe = [&](float p) { return rng_.chance(std::min(1.0f, p * density)); };

    if (type == "bedroom") {
      bedGroup();
      windows(maybe(0.5f) ? 2 : 1);
      if (maybe(0.7f)) wall(models_.wardrobe());
      if (maybe(0.5f)) wall(models_.dresser());
      if (maybe(0.15f)) deskGroup();
      if (maybe(0.2f)) wall(models_.sofa(/*armchair=*/true));
      if (maybe(0.3f)) wall(models_.plant());
      if (maybe(0.35f)) wall(models_.lamp());
      for (int i = 0; i < 2; ++i)
        if (maybe(i == 0 ? 0.6f : 0.25f)) hang(models_.picture());
      if (maybe(0.2f)) hang(models_.mirror());
      if (maybe(0.35f)) center(single(models_.rug(false)), /*rug=*/true);
    } else if (type == "living room") {
      livingGroup();
      windows(maybe(0.6f) ? 2 : 1);
      for (int i = 0; i < 2; ++i)
        if (maybe(i == 0 ? 0.6f : 0.3f)) wall(models_.sofa(/*armchair=*/true));
      if (maybe(0.45f)) wall(models_.bookcase());
      if (maybe(0.3f)) wall(models_.shelf());
      for (int i = 0; i < 2; ++i)
        if (maybe(i == 0 ? 0.7f : 0.4f)) wall(models_.plant());
      if (maybe(0.55f)) wall(models_.lamp());
      if (maybe(0.12f)) wall(models_.piano());
      if (maybe(0.25f)) wall(models_.cabinet());
      for (int i = 0; i < 2; ++i)
        if (maybe(i == 0 ? 0.8f : 0.5f)) hang(models_.picture());
      if (maybe(0.45f)) center(single(models_.rug(false)), /*rug=*/true);
    } else if (type == "kitchen") {
      kitchenRun();
      windows(1);
      if (maybe(0.45f)) center(single(islandModel()), false);
      if (maybe(0.3f)) diningGroup(/*small=*/true);
      if (maybe(0.3f)) wall(models_.cabinet());
      if (maybe(0.2f)) wall(models_.plant());
      if (maybe(0.3f)) hang(models_.picture());
    } else if (type == "dining room") {
      diningGroup(/*small=*/false);
      windows(maybe(0.5f) ? 2 : 1);
      if (maybe(0.5f)) wall(models_.cabinet());
      if (maybe(0.3f)) wall(models_.shelf());
      for (int i = 0; i < 2; ++i)
        if (maybe(i == 0 ? 0.6f : 0.3f)) wall(models_.plant());
      if (maybe(0.3f)) wall(models_.lamp());
      for (int i = 0; i < 2; ++i)
        if (maybe(i == 0 ? 0.7f : 0.3f)) hang(models_.picture());
    } else if (type == "bathroom") {
      wall(models_.toilet());
      const int sinkAt = static_cast<int>(placedModels_.size());
      wall(models_.sink(/*kitchen=*/false, "white", "white"));
      if (static_cast<int>(placedModels_.size()) > sinkAt && maybe(0.75f))
        hangAbove(models_.mirror(), placedModels_.back());
      if (maybe(0.7f)) wall(models_.bathtub());
      if (maybe(0.5f)) windows(1);
      if (maybe(0.35f)) wall(models_.cabinet());
      if (maybe(0.15f)) wall(models_.washer());
      if (maybe(0.2f)) wall(models_.plant());
      if (maybe(0.4f)) center(single(models_.rug(/*small=*/true)), /*rug=*/true);
    } else if (type == "hallway") {
      if (maybe(0.4f)) windows(1);
      if (maybe(0.5f)) wall(models_.plant());
      if (maybe(0.4f)) wall(rng_.chance(0.5f) ? models_.cabinet() : models_.shelf());
      if (maybe(0.2f)) wall(models_.lamp());
      for (int i = 0; i < 3; ++i)
        if (maybe(i == 0 ? 0.7f : 0.4f)) hang(models_.picture());
      if (maybe(0.3f)) hang(models_.mirror());
      if (maybe(0.3f)) center(single(models_.rug(false)), /*rug=*/true);
    } else if (type == "office") {
      deskGroup();
      windows(1);
      if (maybe(0.75f)) wall(models_.bookcase());
      if (maybe(0.35f)) wall(models_.shelf());
      if (maybe(0.45f)) wall(models_.lamp());
      if (maybe(0.5f)) wall(models_.plant());
      if (maybe(0.35f)) wall(models_.cabinet());
      if (maybe(0.3f)) wall(models_.sofa(/*armchair=*/true));
      if (maybe(0.5f)) hang(models_.picture());
      if (maybe(0.3f)) center(single(models_.rug(false)), /*rug=*/true);
    } else if (type == "laundry room") {
      wall(models_.washer());
      if (maybe(0.4f)) wall(models_.washer());
      if (maybe(0.4f)) windows(1);
      if (maybe(0.5f)) wall(models_.cabinet());
      if (maybe(0.5f)) wall(models_.shelf());
      if (maybe(0.3f)) wall(models_.sink(/*kitchen=*/true, "white", "grey"));
    } else if (type == "closet") {
      wall(models_.shelf());
      if (maybe(0.5f)) wall(models_.shelf());
      if (maybe(0.4f)) wall(models_.cabinet());
      if (maybe(0.35f)) wall(models_.dresser());
      if (maybe(0.3f)) hang(models_.mirror());
    }
  }

  // Cuts a hole of size (sx, sz) somewhere free in this room; false if none.
  bool cutHole(float sx, float sz, Box2& hole) {
    const float margin = 0.3f;
    const float x0 = interior_.min().x() + margin, x1 = interior_.max().x() - margin - sx;
    const float z0 = interior_.min().y() + margin, z1 = interior_.max().y() - margin - sz;
    if (x1 <= x0 || z1 <= z0) return false;
    for (int attempt = 0; attempt < 40; ++attempt) {
      // on a 5 cm grid, like the rest of the plan
      const float x = std::round(rng_.uniform(x0, x1) * 20.0f) / 20.0f;
      const float z = std::round(rng_.uniform(z0, z1) * 20.0f) / 20.0f;
      const Box2 candidate(Vec2f(x, z), Vec2f(x + sx, z + sz));
      if (!interior_.contains(candidate)) continue;
      bool clear = true;
      for (const Box2& zone : zones_) clear = clear && !overlaps(candidate, zone, 0.2f);
      for (const Box3& box : placed_) clear = clear && !overlaps(candidate, footprint(box), 0.1f);
      if (!clear) continue;
      if (!navigable({candidate})) continue;
      hole = candidate;
      return true;
    }
    return false;
  }

 private:
  // ---- groups -------------------------------------------------------------
  static Group single(Model m) { return {Member{std::move(m), 0.0f, 0.0f, 0}}; }

  void bedGroup() {
    const Model bed = models_.bed();
    const Model stand = models_.nightstand();
    const float off = bed.width / 2 + 0.05f + stand.width / 2;
    std::vector<Group> variants;
    variants.push_back({{bed}, {stand, -off, 0.0f, 0}, {stand, off, 0.0f, 0}});
    variants.push_back({{bed}, {stand, -off, 0.0f, 0}});
    variants.push_back({{bed}, {stand, off, 0.0f, 0}});
    variants.push_back({{bed}});
    for (const Group& g : variants)
      if (wallGroup(g)) return;
  }

  void livingGroup() {
    const Model sofa = models_.sofa(/*armchair=*/false);
    const Model coffee = models_.table("coffee table", 0.9f, 1.2f, 0.5f, 0.62f, 0.42f,
                                       {"wooden", "white", "black", "brown", "grey"});
    std::vector<Group> variants;
    if (rng_.chance(std::min(1.0f, 0.8f * config_.furniture_density)))
      variants.push_back({{sofa}, {coffee, 0.0f, sofa.depth + 0.4f, 0}});
    variants.push_back({{sofa}});
    for (const Group& g : variants) {
      if (!wallGroup(g)) continue;
      // the tv faces the sofa from the opposite wall when it can
      if (rng_.chance(std::min(1.0f, 0.8f * config_.furniture_density))) {
        const int opposite = lastSide_ ^ 1;
        const float along = lastAlong_;
        if (!wallGroup(single(models_.tv()), opposite, along)) wall(models_.tv());
      }
      return;
    }
  }

  void deskGroup() {
    const Model desk = models_.desk();
    const Model chair = models_.chair(models_.chooseColor({"black", "grey", "white", "blue", "red"}));
    // the chair faces the desk (half a turn), pulled out in front of it
    const float oz = desk.depth + 0.08f + chair.depth;
    if (!wallGroup({{desk}, {chair, 0.2f, oz, 2}})) wallGroup({{desk}});
  }

  void diningGroup(bool small) {
    const Model table = small ? models_.table("table", 0.9f, 1.2f, 0.7f, 0.8f, 0.75f,
                                              {"wooden", "white", "black", "brown"})
                              : models_.table("table", 1.3f, 2.0f, 0.8f, 1.0f, 0.75f,
                                              {"wooden", "white", "black", "brown"});
    const std::string chairColor =
        models_.chooseColor({"wooden", "white", "black", "red", "blue", "green", "yellow", "grey"});
    const Model chair = models_.chair(chairColor);
    const float w = table.width, d = table.depth, dc = chair.depth, gap = 0.05f;
    const int perSide = std::clamp(static_cast<int>((w - 0.1f) / 0.6f), 1, 3);
    auto build = [&](int side, bool ends) {
      // the table is centred on the group origin
      Group g{{table, 0.0f, -d / 2, 0}};
      for (int i = 0; i < side; ++i) {
        const float x = -w / 2 + w * (static_cast<float>(i) + 0.5f) / static_cast<float>(side);
        g.push_back({chair, x, d / 2 + gap + dc, 2});
        g.push_back({chair, -x, -d / 2 - gap - dc, 0});
      }
      if (ends) {
        g.push_back({chair, w / 2 + gap + dc, 0.0f, 3});
        g.push_back({chair, -w / 2 - gap - dc, 0.0f, 1});
      }
      return g;
    };
    std::vector<Group> variants;
    if (!small && w >= 1.5f) variants.push_back(build(perSide, true));
    variants.push_back(build(perSide, false));
    if (perSide > 1) variants.push_back(build(perSide - 1, false));
    variants.push_back(build(1, false));
    variants.push_back({{table, 0.0f, -d / 2, 0}});
    for (const Group& g : variants)
      if (center(g, false)) return;
  }

  Model islandModel() {
    return models_.island(kitchenColor_, kitchenTop_);
  }

  // Fridge, counters, stove and sink packed along walls from a corner.
  void kitchenRun() {
    kitchenColor_ = models_.chooseColor({"white", "wooden", "grey", "blue", "green", "black", "red", "yellow"});
    kitchenTop_ = models_.chooseColor({"black", "grey", "white", "wooden"});
    if (kitchenTop_ == kitchenColor_) kitchenTop_ = kitchenColor_ == "black" ? "grey" : "black";
    std::vector<Model> run;
    run.push_back(models_.fridge());
    run.push_back(models_.counter(kitchenColor_, kitchenTop_, rng_.uniform(0.6f, 1.2f)));
    run.push_back(models_.stove());
    run.push_back(models_.counter(kitchenColor_, kitchenTop_, rng_.uniform(0.4f, 0.9f)));
    run.push_back(models_.sink(/*kitchen=*/true, kitchenColor_, kitchenTop_));
    if (rng_.chance(0.6f))
      run.push_back(models_.counter(kitchenColor_, kitchenTop_, rng_.uniform(0.6f, 1.4f)));
    if (rng_.chance(0.5f)) std::reverse(run.begin(), run.end());
    std::vector<int> sides{0, 1, 2, 3};
    rng_.shuffle(sides);
    size_t side = 0;
    float cursor = -1e9f;
    for (const Model& m : run) {
      bool done = false;
      while (!done && side < sides.size()) {
        done = wallGroup(single(m), sides[side], std::nullopt, cursor);
        if (done) {
          cursor = lastAlongMax_;
        } else {
          ++side;
          cursor = -1e9f;
        }
      }
      if (!done) {
        // out of wall: anywhere that fits
        if (m.category != "counter") wall(m);
        side = 0;
        cursor = -1e9f;
      }
    }
  }

  // ---- placement primitives ----------------------------------------------

  bool wall(const Model& m) { return wallGroup(single(m)); }

  // Windows go on outside walls only.
  void windows(int count) {
    for (int i = 0; i < count; ++i)
      wallGroup(single(models_.window(config_.wall_height)), std::nullopt,
                std::nullopt, std::nullopt,
                [this](int side, float a, float b) { return exterior(side, a, b); });
  }

  // Whether the wall on `side` of this room faces the outside over the
  // along-wall span [a, b] (metres).
  bool exterior(int side, float a, float b) const {
    const RectCm& cell = plan_.rooms[room_].cell;
    // a point 1 cm beyond the cell edge, in centimetres
    const int across = side == 0 ? cell.z0 - 1 : side == 1 ? cell.z1 + 1
                     : side == 2 ? cell.x0 - 1 : cell.x1 + 1;
    for (float t = a; t <= b + 1e-4f; t += 0.05f) {
      const int along = static_cast<int>(std::floor(std::min(t, b) * 100.0f));
      const int x = side < 2 ? along : across;
      const int z = side < 2 ? across : along;
      for (const PlanRoom& other : plan_.rooms)
        if (x > other.cell.x0 && x < other.cell.x1 && z > other.cell.z0 && z < other.cell.z1)
          return false;
    }
    return true;
  }

  // Against a wall. `side`: 0 min z, 1 max z, 2 min x, 3 max x (or any);
  // `prefer`: try along-wall positions nearest to it first; `from`: scan
  // positions upwards from this one (packing runs).
  bool wallGroup(const Group& g, std::optional<int> side = std::nullopt,
                 std::optional<float> prefer = std::nullopt,
                 std::optional<float> from = std::nullopt,
                 const SpanFilter& accept = {}) {
    std::vector<int> sides{0, 1, 2, 3};
    if (side) sides = {*side};
    else rng_.shuffle(sides);
    // the group's extent across the wall (x of the group frame)
    float gx0 = 1e9f, gx1 = -1e9f;
    for (const Member& m : g) {
      for (const Part& p : worldParts(m, 0.0f, 0.0f, 0)) {
        gx0 = std::min(gx0, p.box.min().x());
        gx1 = std::max(gx1, p.box.max().x());
      }
    }
    for (int s : sides) {
      // side -> quarter turns so that the group's front (+z) faces the room
      static const int kTurn[4] = {0, 2, 1, 3};
      const int turn = kTurn[s];
      const bool alongX = s < 2;
      const float lo = alongX ? interior_.min().x() : interior_.min().y();
      const float hi = alongX ? interior_.max().x() : interior_.max().y();
      // along-wall coordinate of the group origin so its extent fits
      const bool flipped = s == 1 || s == 2;  // local +x runs against the axis
      const float tMin = lo + (flipped ? gx1 : -gx0) + kWallGap;
      const float tMax = hi - (flipped ? -gx0 : gx1) - kWallGap;
      if (tMax < tMin) continue;
      // along-wall position t puts the group's near end (towards lower
      // coordinates) at t + nearOffset and its far end at t + farOffset
      const float nearOffset = flipped ? -gx1 : gx0;
      const float farOffset = flipped ? -gx0 : gx1;
      // packing a run: start just past the previous item's far end
      const float first = from ? std::max(tMin, *from - nearOffset + 2 * kObjectGap) : tMin;
      std::vector<float> ts;
      for (float t = first; t <= tMax + 1e-4f; t += 0.05f) ts.push_back(std::min(t, tMax));
      if (ts.empty()) continue;
      if (ts.back() < tMax - 1e-4f) ts.push_back(tMax);
      if (from) {
        // keep the ascending order
      } else if (prefer) {
        std::stable_sort(ts.begin(), ts.end(), [&](float a, float b) {
          return std::abs(a - *prefer) < std::abs(b - *prefer);
        });
      } else {
        rng_.shuffle(ts);
        // corners are where much furniture stands
        if (rng_.chance(0.4f)) {
          ts.insert(ts.begin(), tMax);
          ts.insert(ts.begin(), tMin);
        }
      }
      const float wallAt = s == 0 ? interior_.min().y() + kWallGap
                           : s == 1 ? interior_.max().y() - kWallGap
                           : s == 2 ? interior_.min().x() + kWallGap
                                    : interior_.max().x() - kWallGap;
      for (float t : ts) {
        if (accept && !accept(s, t + nearOffset, t + farOffset)) continue;
        const float ax = alongX ? t : wallAt;
        const float az = alongX ? wallAt : t;
        if (tryPlace(g, ax, az, turn, false)) {
          lastSide_ = s;
          lastAlong_ = t;
          lastAlongMax_ = t + farOffset;
          return true;
        }
      }
    }
    return false;
  }

  // Anywhere on the floor, on a 10 cm grid, in one of four orientations.
  bool center(const Group& g, bool rug) {
    std::vector<Vec2f> anchors;
    for (float x = interior_.min().x(); x <= interior_.max().x(); x += kGridCell)
      for (float z = interior_.min().y(); z <= interior_.max().y(); z += kGridCell)
        anchors.emplace_back(x, z);
    rng_.shuffle(anchors);
    const int tries = std::min<int>(static_cast<int>(anchors.size()), 300);
    for (int i = 0; i < tries; ++i) {
      const int turn = rng_.intIn(0, 3);
      if (tryPlace(g, anchors[i].x(), anchors[i].y(), turn, rug)) return true;
    }
    return false;
  }

  // On a wall, at its model height.
  bool hang(const Model& m) { return wallGroup(single(m)); }

  // On the wall above another object, centred on it when possible.
  void hangAbove(const Model& m, const Box3& below) {
    const Vec2f c = footprint(below).center();
    const int s = lastSide_;
    const float along = s < 2 ? c.x() : c.y();
    if (!wallGroup(single(m), s, along)) hang(m);
  }

  bool tryPlace(const Group& g, float ax, float az, int turn, bool rug) {
    std::vector<std::vector<Part>> parts;
    std::vector<Box3> boxes;
    for (const Member& m : g) {
      parts.push_back(worldParts(m, ax, az, turn));
      const Box3 box = boundsOf(parts.back());
      // inside the room, clear of doorways and of everything placed
      if (!interior_.contains(footprint(box))) return false;
      for (const Box2& zone : zones_)
        if (overlaps(footprint(box), zone, 0.0f)) return false;
      for (const Box3& other : placed_)
        if (overlaps(box, other, kObjectGap)) return false;
      for (const Box3& other : boxes)
        if (overlaps(box, other, kObjectGap)) return false;
      // a rug lies on bare floor only
      if (rug)
        for (const Box3& other : placed_)
          if (overlaps(footprint(box), footprint(other), kObjectGap)) return false;
      boxes.push_back(box);
    }
    const size_t before = placed_.size();
    placed_.insert(placed_.end(), boxes.begin(), boxes.end());
    if (!navigable({})) {
      placed_.resize(before);
      return false;
    }
    for (size_t i = 0; i < g.size(); ++i) {
      PlacedObject object;
      object.semantic.id = static_cast<int>(objects_.size());
      object.semantic.category = g[i].model.category;
      object.semantic.color = g[i].model.color;
      object.semantic.room = room_;
      object.semantic.bounds = boxes[i];
      object.parts = std::move(parts[i]);
      objects_.push_back(std::move(object));
      placedModels_.push_back(boxes[i]);
    }
    return true;
  }

  // Grid search: with `extra` obstacles added, do all doorways of the room
  // connect, and does the agent get next to every object? Cells are free
  // when their centre keeps kAgentClearance from walls and obstacles.
  bool navigable(const std::vector<Box2>& extra) const {
    const int nx = static_cast<int>(interior_.sizes().x() / kGridCell);
    const int nz = static_cast<int>(interior_.sizes().y() / kGridCell);
    if (nx <= 0 || nz <= 0) return false;
    const float ox = interior_.min().x(), oz = interior_.min().y();
    auto cellCenter = [&](int i, int k) {
      return Vec2f(ox + (static_cast<float>(i) + 0.5f) * kGridCell,
                   oz + (static_cast<float>(k) + 0.5f) * kGridCell);
    };
    // cells whose centres may lie within `reach` of `box`
    auto cellRange = [&](const Box2& box, float reach, int& i0, int& i1, int& k0, int& k1) {
      i0 = std::max(0, static_cast<int>((box.min().x() - reach - ox) / kGridCell) - 1);
      i1 = std::min(nx - 1, static_cast<int>((box.max().x() + reach - ox) / kGridCell) + 1);
      k0 = std::max(0, static_cast<int>((box.min().y() - reach - oz) / kGridCell) - 1);
      k1 = std::min(nz - 1, static_cast<int>((box.max().y() + reach - oz) / kGridCell) + 1);
    };

    // walls, then each obstacle over the cells near it
    std::vector<uint8_t> free(static_cast<size_t>(nx) * nz, 0);
    for (int k = 0; k < nz; ++k)
      for (int i = 0; i < nx; ++i) {
        const Vec2f p = cellCenter(i, k);
        const float toWall = std::min({p.x() - ox, interior_.max().x() - p.x(),
                                       p.y() - oz, interior_.max().y() - p.y()});
        free[static_cast<size_t>(k) * nx + i] = toWall >= kAgentClearance;
      }
    auto block = [&](const Box2& box) {
      int i0, i1, k0, k1;
      cellRange(box, kAgentClearance, i0, i1, k0, k1);
      for (int k = k0; k <= k1; ++k)
        for (int i = i0; i <= i1; ++i)
          if (distanceToBox(cellCenter(i, k), box) < kAgentClearance)
            free[static_cast<size_t>(k) * nx + i] = 0;
    };
    for (const Box2& box : extra) block(box);
    for (const Box3& box : placed_)
      if (blocksWalking(box)) block(footprint(box));

    auto cellOf = [&](const Vec2f& p) {
      const int i = std::clamp(static_cast<int>((p.x() - ox) / kGridCell), 0, nx - 1);
      const int k = std::clamp(static_cast<int>((p.y() - oz) / kGridCell), 0, nz - 1);
      return static_cast<size_t>(k) * nx + i;
    };
    // flood fill from the first doorway
    std::vector<uint8_t> reached(free.size(), 0);
    const size_t start = cellOf(seeds_.front());
    if (!free[start]) return false;
    std::vector<size_t> stack{start};
    reached[start] = 1;
    while (!stack.empty()) {
      const size_t c = stack.back();
      stack.pop_back();
      const int i = static_cast<int>(c % nx), k = static_cast<int>(c / nx);
      const int di[4] = {1, -1, 0, 0}, dk[4] = {0, 0, 1, -1};
      for (int n = 0; n < 4; ++n) {
        const int ii = i + di[n], kk = k + dk[n];
        if (ii < 0 || kk < 0 || ii >= nx || kk >= nz) continue;
        const size_t nc = static_cast<size_t>(kk) * nx + ii;
        if (free[nc] && !reached[nc]) {
          reached[nc] = 1;
          stack.push_back(nc);
        }
      }
    }
    for (const Vec2f& seed : seeds_)
      if (!reached[cellOf(seed)]) return false;
    // every object (rugs included) has a reachable spot beside it; things
    // hung on walls may be seen from a little further (over a sofa, say)
    for (const Box3& box : placed_) {
      const Box2 fp = footprint(box);
      const float reach = kAgentClearance + (box.min().y() > 0.8f ? kHungReach : kReachSlack);
      int i0, i1, k0, k1;
      cellRange(fp, reach, i0, i1, k0, k1);
      bool near = false;
      for (int k = k0; k <= k1 && !near; ++k)
        for (int i = i0; i <= i1 && !near; ++i)
          near = reached[static_cast<size_t>(k) * nx + i] &&
                 distanceToBox(cellCenter(i, k), fp) <= reach;
      if (!near) return false;
    }
    return true;
  }

  Rng& rng_;
  const FloorPlan& plan_;
  int room_;
  const HouseConfig& config_;
  std::vector<PlacedObject>& objects_;
  ModelBuilder models_;
  Box2 interior_;
  std::vector<Box2> zones_;
  std::vector<Vec2f> seeds_;
  std::vector<Box3> placed_;        // bounds of this room's objects
  std::vector<Box3> placedModels_;  // same, in placement order (for hangAbove)
  int lastSide_ = 0;
  float lastAlong_ = 0.0f;
  float lastAlongMax_ = 0.0f;
  std::string kitchenColor_ = "white";
  std::string kitchenTop_ = "black";
};

}  // namespace

// ===========================================================================
// entry points
// ===========================================================================

std::vector<PlacedObject> furnish(Rng& rng, const FloorPlan& plan,
                                  const HouseConfig& config,
                                  std::vector<Eigen::AlignedBox2f>& holes) {
  std::vector<PlacedObject> objects;
  for (size_t r = 0; r < plan.rooms.size(); ++r) {
    // each room draws from its own stream: changing one room's recipe
    // leaves the others unchanged
    Rng roomRng = rng.fork(r);
    RoomFurnisher(roomRng, plan, static_cast<int>(r), config, objects)
        .furnish(plan.rooms[r].type);
  }

  Rng holeRng = rng.fork(0x401E);
  if (holeRng.chance(config.floor_hole_probability)) {
    std::vector<int> rooms;
    for (size_t r = 0; r < plan.rooms.size(); ++r)
      if (plan.rooms[r].type != "closet") rooms.push_back(static_cast<int>(r));
    holeRng.shuffle(rooms);
    const float sx = std::round(holeRng.uniform(0.5f, 1.0f) * 20.0f) / 20.0f;
    const float sz = std::round(holeRng.uniform(0.5f, 1.0f) * 20.0f) / 20.0f;
    for (int r : rooms) {
      Box2 hole;
      if (RoomFurnisher(holeRng, plan, r, config, objects).cutHole(sx, sz, hole)) {
        holes.push_back(hole);
        break;
      }
    }
  }
  return objects;
}

}  // namespace vln::sim::house
