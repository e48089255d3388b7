// The furniture catalogue of procedural houses: landmark models (beds,
// sofas, tables, kitchens, bathrooms, pictures, windows, ...) built from
// boxes, cylinders, cones and spheres in the model frame of HouseBuilder.h,
// with random sizes and colours (kitchen, bathroom and laundry fittings are
// HouseBuilderFittings.cpp). The colour name of a model is the colour
// of its largest visible part; other parts use neutral colours.

// First of all includes: no FMA contraction (see the header).
#include "world/HouseFpContract.h"

#include <algorithm>
#include <vector>

#include "world/HouseBuilder.h"

namespace vln::world::house {
namespace {

// ===========================================================================
// colours
// ===========================================================================

const Rgb8 kLinen{238, 236, 228};
const Rgb8 kGlass{196, 210, 220};
const Rgb8 kSoil{70, 50, 36};
const std::vector<Rgb8> kFoliage = {
    {62, 128, 58}, {48, 110, 52}, {84, 140, 64}};
const std::vector<Rgb8> kBookColors = {
    {150, 40, 40},  {40, 70, 140},  {40, 110, 60},
    {200, 170, 60}, {120, 80, 50},  {220, 220, 210},
    {60, 60, 64},   {180, 100, 40}, {110, 60, 130}};

}  // namespace

Rgb8 scaled(const Rgb8& c, float f) {
  auto s = [f](uint8_t v) {
    return static_cast<uint8_t>(
        std::clamp(static_cast<float>(v) * f + 0.5f, 0.0f, 255.0f));
  };
  return {s(c[0]), s(c[1]), s(c[2])};
}

// ===========================================================================
// models
// ===========================================================================

std::string ModelBuilder::chooseColor(const std::vector<const char*>& names) {
  return names[rng_.intIn(0, static_cast<int>(names.size()) - 1)];
}

Surface ModelBuilder::finishOf(const std::string& color, Surface otherwise) {
  return color == "wooden" ? Surface::kWood : otherwise;
}

Model ModelBuilder::bed() {
  Model m = start("bed", {"red", "blue", "green", "yellow", "white", "grey",
                          "purple", "pink", "orange"});
  const bool twin = rng_.chance(0.35f);
  const float w = twin ? rng_.uniform(0.9f, 1.0f) : rng_.uniform(1.4f, 1.8f);
  const float d = rng_.uniform(2.0f, 2.15f);
  const float head = height(rng_.uniform(0.95f, 1.15f));
  const std::string frameName =
      chooseColor({"wooden", "white", "black", "grey", "brown"});
  const Rgb8 frame = namedColor(frameName);
  const Surface frameFinish = finishOf(frameName, Surface::kPlain);
  const Rgb8 duvet = namedColor(m.color);
  m.width = w;
  m.depth = d;
  box(m, -w / 2, 0.0f, 0.06f, w / 2, 0.3f, d, frame, frameFinish);
  box(m, -w / 2, 0.0f, 0.0f, w / 2, head, 0.06f, frame, frameFinish);
  box(m, -w / 2 + 0.03f, 0.3f, 0.08f, w / 2 - 0.03f, 0.5f, d - 0.03f, kLinen,
      Surface::kFabric);
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

Model ModelBuilder::nightstand() {
  Model m = start("nightstand", {"wooden", "white", "black", "brown", "grey"});
  const float w = rng_.uniform(0.42f, 0.52f), d = 0.4f,
              h = rng_.uniform(0.5f, 0.6f);
  m.width = w;
  m.depth = d;
  const Rgb8 c = namedColor(m.color);
  const Surface f = finishOf(m.color, Surface::kPlain);
  box(m, -w / 2, 0.0f, 0.0f, w / 2, h, d - 0.01f, c, f);
  box(m, -w / 2 + 0.03f, h * 0.55f, d - 0.01f, w / 2 - 0.03f, h * 0.56f, d,
      scaled(c, 0.6f), Surface::kPlain);
  box(m, -0.03f, h * 0.72f, d - 0.01f, 0.03f, h * 0.76f, d, kMetal,
      Surface::kPlain);
  return m;
}

Model ModelBuilder::wardrobe() {
  Model m = start("wardrobe", {"wooden", "white", "brown", "grey", "black"});
  const float w = rng_.uniform(1.0f, 1.6f), d = 0.6f,
              h = height(rng_.uniform(1.9f, 2.1f));
  m.width = w;
  m.depth = d;
  const Rgb8 c = namedColor(m.color);
  box(m, -w / 2, 0.0f, 0.0f, w / 2, h, d - 0.01f, c,
      finishOf(m.color, Surface::kPlain));
  box(m, -0.005f, 0.05f, d - 0.01f, 0.005f, h - 0.05f, d, scaled(c, 0.55f),
      Surface::kPlain);
  for (float x : {-0.06f, 0.04f})
    box(m, x, h * 0.45f, d - 0.01f, x + 0.02f, h * 0.6f, d, kMetal,
        Surface::kPlain);
  return m;
}

Model ModelBuilder::dresser() {
  Model m =
      start("dresser", {"wooden", "white", "brown", "black", "grey", "blue"});
  const float w = rng_.uniform(1.0f, 1.4f), d = 0.5f,
              h = rng_.uniform(0.8f, 0.92f);
  m.width = w;
  m.depth = d;
  const Rgb8 c = namedColor(m.color);
  box(m, -w / 2, 0.0f, 0.0f, w / 2, h, d - 0.01f, c,
      finishOf(m.color, Surface::kPlain));
  for (int i = 1; i <= 3; ++i) {
    const float y = h * static_cast<float>(i) / 4.0f;
    box(m, -w / 2 + 0.03f, y - 0.005f, d - 0.01f, w / 2 - 0.03f, y + 0.005f, d,
        scaled(c, 0.6f), Surface::kPlain);
    box(m, -0.05f, y + 0.06f, d - 0.01f, 0.05f, y + 0.08f, d, kMetal,
        Surface::kPlain);
  }
  return m;
}

Model ModelBuilder::sofa(bool armchair) {
  Model m = start(armchair ? "armchair" : "sofa",
                  {"red", "blue", "green", "grey", "brown", "black", "yellow",
                   "orange", "purple", "white", "pink"});
  const float w =
      armchair ? rng_.uniform(0.8f, 0.95f) : rng_.uniform(1.8f, 2.4f);
  const float d = rng_.uniform(0.85f, 0.95f), h = rng_.uniform(0.8f, 0.9f);
  m.width = w;
  m.depth = d;
  const Rgb8 c = namedColor(m.color);
  const Surface f = Surface::kFabric;
  const float arm = 0.16f;
  legs(m, -w / 2 + 0.03f, w / 2 - 0.08f, 0.03f, d - 0.08f, 0.05f, 0.1f, kDark,
       Surface::kPlain);
  box(m, -w / 2, 0.1f, 0.0f, w / 2, 0.42f, d, scaled(c, 0.9f), f);
  box(m, -w / 2, 0.42f, 0.0f, w / 2, h, 0.22f, c, f);
  box(m, -w / 2, 0.42f, 0.0f, -w / 2 + arm, 0.64f, d, c, f);
  box(m, w / 2 - arm, 0.42f, 0.0f, w / 2, 0.64f, d, c, f);
  const int cushions = armchair ? 1 : (w > 2.1f ? 3 : 2);
  const float span = w - 2 * arm;
  for (int i = 0; i < cushions; ++i) {
    const float x0 = -w / 2 + arm + span * static_cast<float>(i) / cushions;
    const float x1 = -w / 2 + arm + span * static_cast<float>(i + 1) / cushions;
    box(m, x0 + 0.01f, 0.42f, 0.22f, x1 - 0.01f, 0.54f, d - 0.02f,
        scaled(c, 1.08f), f);
  }
  return m;
}

Model ModelBuilder::table(const char* category, float wLo, float wHi, float dLo,
                          float dHi, float h, std::vector<const char*> colors) {
  Model m = start(category, colors);
  const float w = rng_.uniform(wLo, wHi), d = rng_.uniform(dLo, dHi);
  m.width = w;
  m.depth = d;
  const Rgb8 c = namedColor(m.color);
  const Surface f = finishOf(m.color, Surface::kPlain);
  box(m, -w / 2, h - 0.04f, 0.0f, w / 2, h, d, c, f);
  const float leg = 0.06f, inset = 0.05f;
  legs(m, -w / 2 + inset, w / 2 - inset - leg, inset, d - inset - leg, leg,
       h - 0.04f, scaled(c, 0.85f), f);
  return m;
}

Model ModelBuilder::chair(const std::string& color) {
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
  legs(m, -w / 2, w / 2 - leg, 0.0f, d - leg, leg, 0.42f, scaled(c, 0.85f), f);
  return m;
}

Model ModelBuilder::tv() {
  Model m = start("tv", {"black", "black", "grey", "white"});
  const float w = rng_.uniform(1.2f, 1.6f), d = 0.42f,
              standH = rng_.uniform(0.42f, 0.55f);
  m.width = w;
  m.depth = d;
  const std::string standName =
      chooseColor({"wooden", "white", "black", "grey"});
  const Rgb8 stand = namedColor(standName);
  box(m, -w / 2, 0.0f, 0.0f, w / 2, standH, d, stand,
      finishOf(standName, Surface::kPlain));
  const float sw = std::min(w - 0.1f, rng_.uniform(0.9f, 1.3f));
  const float sh = sw * 0.58f;
  const Rgb8 bezel = namedColor(m.color);
  box(m, -0.12f, standH, 0.1f, 0.12f, standH + 0.02f, 0.28f, bezel,
      Surface::kPlain);
  box(m, -0.03f, standH + 0.02f, 0.16f, 0.03f, standH + 0.1f, 0.2f, bezel,
      Surface::kPlain);
  box(m, -sw / 2, standH + 0.1f, 0.15f, sw / 2, standH + 0.1f + sh, 0.2f, bezel,
      Surface::kPlain);
  box(m, -sw / 2 + 0.02f, standH + 0.12f, 0.2f, sw / 2 - 0.02f,
      standH + 0.08f + sh, 0.205f, kScreen, Surface::kPlain);
  return m;
}

Model ModelBuilder::plant() {
  Model m;
  m.category = "plant";
  m.color = "green";
  const float potR = rng_.uniform(0.13f, 0.2f),
              potH = rng_.uniform(0.25f, 0.4f);
  const int style = rng_.intIn(0, 2);
  const float crown = style == 1 ? potR * 2.2f : rng_.uniform(0.45f, 0.7f);
  const float w = std::max(2 * potR, crown);
  m.width = w;
  m.depth = w;
  const std::vector<Rgb8> pots = {{236, 236, 232},
                                  {128, 128, 128},
                                  {182, 92, 60},
                                  {40, 40, 42},
                                  {60, 90, 160}};
  const Rgb8 pot = pots[rng_.intIn(0, static_cast<int>(pots.size()) - 1)];
  const float cz = w / 2;
  shape(m, Shape::kCylinderY, -potR, 0.0f, cz - potR, potR, potH, cz + potR,
        pot);
  shape(m, Shape::kCylinderY, -potR * 0.85f, potH, cz - potR * 0.85f,
        potR * 0.85f, potH + 0.01f, cz + potR * 0.85f, kSoil);
  const Rgb8 leaf =
      kFoliage[rng_.intIn(0, static_cast<int>(kFoliage.size()) - 1)];
  if (style == 0) {
    // bushy: a crown of two spheres
    const float top = potH + crown;
    shape(m, Shape::kSphere, -crown / 2, potH, cz - crown / 2, crown / 2, top,
          cz + crown / 2, leaf);
    shape(m, Shape::kSphere, -crown / 3, top - crown * 0.45f, cz - crown / 3,
          crown / 3, top + crown * 0.25f, cz + crown / 3, scaled(leaf, 1.12f));
  } else if (style == 1) {
    // a small tree: a cone of foliage
    const float h = height(potH + rng_.uniform(0.9f, 1.3f));
    shape(m, Shape::kConeY, -crown / 2, potH + 0.05f, cz - crown / 2, crown / 2,
          h, cz + crown / 2, leaf);
  } else {
    // a tall plant: trunk and a high crown
    const float h = height(potH + rng_.uniform(1.0f, 1.4f));
    shape(m, Shape::kCylinderY, -0.025f, potH, cz - 0.025f, 0.025f,
          h - crown * 0.5f, cz + 0.025f, {96, 70, 48});
    shape(m, Shape::kSphere, -crown / 2, h - crown, cz - crown / 2, crown / 2,
          h, cz + crown / 2, leaf);
  }
  return m;
}

Model ModelBuilder::lamp() {
  Model m = start("lamp", {"white", "yellow", "orange", "red", "blue", "green",
                           "black", "grey"});
  const float r = rng_.uniform(0.18f, 0.25f), pole = rng_.uniform(1.25f, 1.45f);
  m.width = 2 * r;
  m.depth = 2 * r;
  const float cz = r;
  shape(m, Shape::kCylinderY, -0.14f, 0.0f, cz - 0.14f, 0.14f, 0.03f,
        cz + 0.14f, kDark);
  shape(m, Shape::kCylinderY, -0.015f, 0.03f, cz - 0.015f, 0.015f, pole,
        cz + 0.015f, kMetal);
  shape(m, Shape::kFrustumY, -r, pole - 0.08f, cz - r, r, height(pole + 0.25f),
        cz + r, namedColor(m.color));
  return m;
}

Model ModelBuilder::bookcase() {
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
  box(m, -w / 2 + 0.02f, 0.06f, 0.0f, w / 2 - 0.02f, h - 0.02f, 0.01f,
      scaled(c, 0.8f), f);
  const int shelves = rng_.intIn(4, 5);
  const float step = (h - 0.08f) / static_cast<float>(shelves);
  for (int s = 0; s < shelves; ++s) {
    const float y = 0.06f + step * static_cast<float>(s);
    if (s > 0)
      box(m, -w / 2 + 0.02f, y - 0.02f, 0.01f, w / 2 - 0.02f, y, d, c, f);
    books(m, -w / 2 + 0.03f, w / 2 - 0.03f, y, std::min(step - 0.05f, 0.3f), d);
  }
  return m;
}

Model ModelBuilder::shelf() {
  Model m = start("shelf", {"wooden", "white", "black", "grey"});
  const float w = rng_.uniform(0.8f, 1.4f), d = rng_.uniform(0.3f, 0.36f),
              h = rng_.uniform(0.8f, 1.1f);
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
    if (b < boards)
      books(m, -w / 2 + 0.04f, w / 2 - 0.04f, y, h / boards - 0.06f, d);
  }
  return m;
}

Model ModelBuilder::desk() {
  Model m = start("desk", {"wooden", "white", "black", "grey"});
  const float w = rng_.uniform(1.2f, 1.6f), d = rng_.uniform(0.6f, 0.7f),
              h = 0.75f;
  m.width = w;
  m.depth = d;
  const Rgb8 c = namedColor(m.color);
  const Surface f = finishOf(m.color, Surface::kPlain);
  box(m, -w / 2, h - 0.03f, 0.0f, w / 2, h, d, c, f);
  box(m, -w / 2, 0.0f, 0.0f, -w / 2 + 0.42f, h - 0.03f, d - 0.02f,
      scaled(c, 0.92f), f);
  box(m, w / 2 - 0.03f, 0.0f, 0.0f, w / 2, h - 0.03f, d - 0.02f,
      scaled(c, 0.92f), f);
  for (int i = 1; i <= 2; ++i) {
    const float y = (h - 0.03f) * static_cast<float>(i) / 3.0f;
    box(m, -w / 2 + 0.03f, y - 0.004f, d - 0.02f, -w / 2 + 0.39f, y + 0.004f,
        d - 0.01f, scaled(c, 0.6f), Surface::kPlain);
  }
  if (rng_.chance(0.6f)) {
    // a monitor on the desk
    const float mw = rng_.uniform(0.5f, 0.65f);
    box(m, -0.1f, h, 0.08f, 0.1f, h + 0.015f, 0.22f, kDark, Surface::kPlain);
    box(m, -0.02f, h + 0.015f, 0.12f, 0.02f, h + 0.12f, 0.16f, kDark,
        Surface::kPlain);
    box(m, -mw / 2, h + 0.12f, 0.1f, mw / 2, h + 0.12f + mw * 0.6f, 0.13f,
        kDark, Surface::kPlain);
    box(m, -mw / 2 + 0.015f, h + 0.135f, 0.13f, mw / 2 - 0.015f,
        h + 0.105f + mw * 0.6f, 0.133f, kScreen, Surface::kPlain);
  }
  return m;
}

Model ModelBuilder::cabinet() {
  Model m =
      start("cabinet", {"wooden", "white", "grey", "blue", "green", "black"});
  const float w = rng_.uniform(0.6f, 1.2f), d = 0.45f,
              h = rng_.uniform(0.8f, 1.2f);
  m.width = w;
  m.depth = d;
  const Rgb8 c = namedColor(m.color);
  box(m, -w / 2, 0.0f, 0.0f, w / 2, 0.08f, d - 0.04f, kDark, Surface::kPlain);
  box(m, -w / 2, 0.08f, 0.0f, w / 2, h, d - 0.01f, c,
      finishOf(m.color, Surface::kPlain));
  const int doors = w > 0.8f ? 2 : 1;
  if (doors == 2)
    box(m, -0.004f, 0.1f, d - 0.01f, 0.004f, h - 0.02f, d, scaled(c, 0.55f),
        Surface::kPlain);
  for (int i = 0; i < doors; ++i) {
    const float x = doors == 1 ? w / 2 - 0.08f : (i == 0 ? -0.06f : 0.04f);
    box(m, x, h - 0.25f, d - 0.01f, x + 0.02f, h - 0.1f, d, kMetal,
        Surface::kPlain);
  }
  return m;
}

Model ModelBuilder::rug(bool small) {
  Model m = start("rug", {"red", "blue", "green", "grey", "brown", "orange",
                          "purple", "pink", "yellow"});
  const float w = small ? rng_.uniform(0.6f, 0.9f) : rng_.uniform(1.2f, 2.4f);
  const float d =
      small ? rng_.uniform(0.4f, 0.6f) : rng_.uniform(0.8f, std::min(1.7f, w));
  m.width = w;
  m.depth = d;
  const Rgb8 c = namedColor(m.color);
  const float border = std::min(0.08f, 0.1f * d);
  box(m, -w / 2, 0.0f, 0.0f, w / 2, 0.01f, d, scaled(c, 0.7f),
      Surface::kCarpet);
  box(m, -w / 2 + border, 0.01f, border, w / 2 - border, 0.012f, d - border, c,
      Surface::kCarpet);
  return m;
}

Model ModelBuilder::picture() {
  Model m = start("picture", {"red", "blue", "green", "yellow", "orange",
                              "purple", "pink"});
  m.hung = true;
  const float w = rng_.uniform(0.4f, 1.0f),
              h = rng_.uniform(0.3f, std::min(0.8f, w * 1.2f));
  const float center = rng_.uniform(1.45f, 1.6f);
  const float y0 = center - h / 2, y1 = center + h / 2;
  m.width = w;
  m.depth = 0.04f;
  const Rgb8 frame = namedColor(chooseColor({"black", "white", "grey"}));
  const float f = 0.035f;
  box(m, -w / 2, y0, 0.0f, w / 2, y1, 0.035f, frame, Surface::kPlain);
  box(m, -w / 2 + f, y0 + f, 0.035f, w / 2 - f, y1 - f, 0.037f,
      namedColor(m.color), Surface::kPlain);
  // a few small shapes of other colours; the named colour stays dominant
  const int marks = rng_.intIn(1, 3);
  for (int i = 0; i < marks; ++i) {
    const float mw = (w - 2 * f) * rng_.uniform(0.1f, 0.25f);
    const float mh = (h - 2 * f) * rng_.uniform(0.1f, 0.3f);
    const float mx = rng_.uniform(-w / 2 + f, w / 2 - f - mw);
    const float my = rng_.uniform(y0 + f, y1 - f - mh);
    const Rgb8 mark =
        kBookColors[rng_.intIn(0, static_cast<int>(kBookColors.size()) - 1)];
    box(m, mx, my, 0.037f, mx + mw, my + mh, 0.04f, mark, Surface::kPlain);
  }
  return m;
}

Model ModelBuilder::mirror() {
  Model m = start("mirror", {"white", "black", "wooden", "grey"});
  m.hung = true;
  const float w = rng_.uniform(0.5f, 0.8f), h = rng_.uniform(0.7f, 0.95f);
  const float y0 = rng_.uniform(1.1f, 1.2f);
  m.width = w;
  m.depth = 0.035f;
  box(m, -w / 2, y0, 0.0f, w / 2, y0 + h, 0.03f, namedColor(m.color),
      finishOf(m.color, Surface::kPlain));
  box(m, -w / 2 + 0.04f, y0 + 0.04f, 0.03f, w / 2 - 0.04f, y0 + h - 0.04f,
      0.035f, kGlass, Surface::kPlain);
  return m;
}

Model ModelBuilder::window(float wallHeight, const std::string& color) {
  Model m;
  m.category = "window";
  m.color = color;
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
  box(m, -w / 2 + b, mid - 0.02f, 0.03f, w / 2 - b, mid + 0.02f, 0.05f, frame,
      f);
  box(m, -w / 2 - 0.0f, y0 - 0.03f, 0.0f, w / 2, y0, 0.1f, frame, f);
  return m;
}

Model ModelBuilder::piano() {
  Model m = start("piano", {"black", "black", "brown", "white"});
  const float w = rng_.uniform(1.45f, 1.55f), d = 0.62f,
              h = rng_.uniform(1.15f, 1.25f);
  m.width = w;
  m.depth = d;
  const Rgb8 c = namedColor(m.color);
  box(m, -w / 2, 0.0f, 0.0f, w / 2, h, 0.36f, c, Surface::kPlain);
  box(m, -w / 2, 0.68f, 0.36f, w / 2, 0.72f, 0.58f, c, Surface::kPlain);
  box(m, -w / 2 + 0.05f, 0.72f, 0.38f, w / 2 - 0.05f, 0.75f, 0.58f,
      {244, 244, 238}, Surface::kPlain);
  box(m, -w / 2 + 0.05f, 0.75f, 0.38f, w / 2 - 0.05f, 0.765f, 0.46f, kScreen,
      Surface::kPlain);
  for (float x : {-w / 2 + 0.02f, w / 2 - 0.07f})
    box(m, x, 0.0f, 0.52f, x + 0.05f, 0.68f, d, c, Surface::kPlain);
  return m;
}

Model ModelBuilder::start(const char* category,
                          std::vector<const char*> colors) {
  Model m;
  m.category = category;
  m.color = chooseColor(colors);
  return m;
}

float ModelBuilder::height(float h) const { return std::min(h, maxHeight_); }

void ModelBuilder::box(Model& m, float x0, float y0, float z0, float x1,
                       float y1, float z1, const Rgb8& color, Surface surface) {
  shape(m, Shape::kBox, x0, y0, z0, x1, y1, z1, color, surface);
}

void ModelBuilder::legs(Model& m, float x0, float x1, float z0, float z1,
                        float size, float top, const Rgb8& color,
                        Surface surface) {
  for (float x : {x0, x1})
    for (float z : {z0, z1})
      box(m, x, 0.0f, z, x + size, top, z + size, color, surface);
}

void ModelBuilder::shape(Model& m, Shape s, float x0, float y0, float z0,
                         float x1, float y1, float z1, const Rgb8& color,
                         Surface surface) {
  Part p;
  p.shape = s;
  p.box = Eigen::AlignedBox3f(Vec3f(x0, std::min(y0, maxHeight_), z0),
                              Vec3f(x1, std::min(y1, maxHeight_), z1));
  p.color = color;
  p.surface = surface;
  m.parts.push_back(p);
}

void ModelBuilder::books(Model& m, float x0, float x1, float y, float maxH,
                         float d) {
  float x = x0 + rng_.uniform(0.0f, 0.08f);
  int count = 0;
  while (x < x1 - 0.06f && count < 8 && maxH > 0.1f) {
    const float bw = rng_.uniform(0.025f, 0.06f);
    const float bh = rng_.uniform(0.6f, 0.95f) * maxH;
    const Rgb8 color =
        kBookColors[rng_.intIn(0, static_cast<int>(kBookColors.size()) - 1)];
    box(m, x, y, 0.03f, std::min(x + bw, x1), y + bh,
        d - rng_.uniform(0.03f, 0.08f), color, Surface::kPlain);
    x += bw + (rng_.chance(0.15f) ? rng_.uniform(0.05f, 0.2f) : 0.002f);
    ++count;
  }
}

}  // namespace vln::world::house