// The kitchen, bathroom and laundry fittings of the furniture catalogue
// (HouseBuilderModels.cpp has the rest): counters, the kitchen island,
// sinks, stove, fridge, toilet, bathtub and washing machine, built like the
// other models in the model frame of HouseBuilder.h.

// First of all includes: no FMA contraction (see the header).
#include "world/HouseFpContract.h"

#include <algorithm>
#include <string>

#include "world/HouseBuilder.h"

namespace vln::world::house {

Model ModelBuilder::counter(const std::string& color,
                            const std::string& topName, float w) {
  Model m;
  m.category = "counter";
  m.color = color;
  const float d = 0.62f, h = 0.9f;
  m.width = w;
  m.depth = d;
  counterBody(m, color, topName, w, d, h, /*doors=*/true);
  return m;
}

Model ModelBuilder::island(const std::string& color,
                           const std::string& topName) {
  Model m;
  m.category = "kitchen island";
  m.color = color;
  const float w = rng_.uniform(1.5f, 2.2f), d = rng_.uniform(0.9f, 1.0f),
              h = 0.92f;
  m.width = w;
  m.depth = d;
  const Rgb8 c = namedColor(color);
  box(m, -w / 2 + 0.05f, 0.0f, 0.05f, w / 2 - 0.05f, h - 0.04f, d - 0.05f, c,
      finishOf(color, Surface::kPlain));
  box(m, -w / 2, h - 0.04f, 0.0f, w / 2, h, d, namedColor(topName),
      finishOf(topName, Surface::kPlain));
  return m;
}

Model ModelBuilder::sink(bool kitchen, const std::string& color,
                         const std::string& topName) {
  Model m;
  m.category = "sink";
  if (kitchen) {
    m.color = "grey";
    const float w = rng_.uniform(0.8f, 1.0f), d = 0.62f, h = 0.9f;
    m.width = w;
    m.depth = d;
    counterBody(m, color, topName, w, d, h, /*doors=*/true);
    box(m, -0.3f, h, 0.12f, 0.3f, h + 0.012f, 0.52f, kSteel, Surface::kPlain);
    box(m, -0.26f, h + 0.012f, 0.16f, 0.26f, h + 0.014f, 0.48f,
        scaled(kSteel, 0.7f), Surface::kPlain);
    shape(m, Shape::kCylinderY, -0.02f, h, 0.04f, 0.02f, h + 0.3f, 0.08f,
          kSteel);
  } else {
    m.color = "white";
    const float w = rng_.uniform(0.55f, 0.8f), d = 0.48f;
    m.width = w;
    m.depth = d;
    const Rgb8 white = namedColor("white");
    if (rng_.chance(0.5f)) {
      // pedestal sink
      shape(m, Shape::kCylinderY, -0.09f, 0.0f, 0.12f, 0.09f, 0.7f, 0.3f,
            white);
      box(m, -w / 2, 0.7f, 0.0f, w / 2, 0.86f, d, white, Surface::kPlain);
    } else {
      // vanity cabinet with a basin top
      const Rgb8 cab = namedColor(chooseColor({"wooden", "white", "grey"}));
      box(m, -w / 2, 0.0f, 0.0f, w / 2, 0.8f, d - 0.02f, cab, Surface::kPlain);
      box(m, -w / 2, 0.8f, 0.0f, w / 2, 0.86f, d, white, Surface::kPlain);
    }
    box(m, -w / 2 + 0.08f, 0.86f, 0.12f, w / 2 - 0.08f, 0.865f, d - 0.06f,
        scaled(white, 0.85f), Surface::kPlain);
    shape(m, Shape::kCylinderY, -0.015f, 0.86f, 0.04f, 0.015f, 1.05f, 0.07f,
          kSteel);
  }
  return m;
}

Model ModelBuilder::stove() {
  Model m = start("stove", {"white", "black", "grey"});
  const float w = 0.6f, d = 0.62f, h = 0.9f;
  m.width = w;
  m.depth = d;
  const Rgb8 c = namedColor(m.color);
  box(m, -w / 2, 0.0f, 0.0f, w / 2, h - 0.02f, d - 0.02f, c, Surface::kPlain);
  box(m, -w / 2, h - 0.02f, 0.0f, w / 2, h, d - 0.02f, kDark, Surface::kPlain);
  for (float x : {-0.14f, 0.14f})
    for (float z : {0.16f, 0.42f})
      shape(m, Shape::kCylinderY, x - 0.085f, h, z - 0.085f, x + 0.085f,
            h + 0.01f, z + 0.085f, {60, 60, 62});
  box(m, -w / 2 + 0.06f, 0.15f, d - 0.02f, w / 2 - 0.06f, 0.6f, d - 0.01f,
      kScreen, Surface::kPlain);
  shape(m, Shape::kCylinderX, -w / 2 + 0.08f, 0.66f, d - 0.02f, w / 2 - 0.08f,
        0.68f, d, kSteel);
  box(m, -w / 2 + 0.03f, 0.74f, d - 0.02f, w / 2 - 0.03f, 0.84f, d - 0.01f,
      scaled(c, 0.7f), Surface::kPlain);
  return m;
}

Model ModelBuilder::fridge() {
  Model m = start("fridge", {"white", "white", "grey", "black", "red"});
  const float w = rng_.uniform(0.6f, 0.8f), d = 0.68f,
              h = height(rng_.uniform(1.7f, 1.9f));
  m.width = w;
  m.depth = d;
  const Rgb8 c = namedColor(m.color);
  box(m, -w / 2, 0.0f, 0.0f, w / 2, h, d - 0.03f, c, Surface::kPlain);
  box(m, -w / 2 + 0.01f, h * 0.62f - 0.005f, d - 0.03f, w / 2 - 0.01f,
      h * 0.62f + 0.005f, d - 0.025f, scaled(c, 0.6f), Surface::kPlain);
  box(m, w / 2 - 0.07f, h * 0.35f, d - 0.025f, w / 2 - 0.05f, h * 0.58f, d,
      kSteel, Surface::kPlain);
  box(m, w / 2 - 0.07f, h * 0.66f, d - 0.025f, w / 2 - 0.05f, h * 0.8f, d,
      kSteel, Surface::kPlain);
  return m;
}

Model ModelBuilder::toilet() {
  Model m = start("toilet", {"white", "white", "white", "black"});
  const float w = 0.4f, d = 0.7f;
  m.width = w;
  m.depth = d;
  const Rgb8 c = namedColor(m.color);
  box(m, -0.19f, 0.4f, 0.0f, 0.19f, 0.8f, 0.18f, c, Surface::kPlain);
  box(m, -0.11f, 0.0f, 0.18f, 0.11f, 0.3f, 0.55f, c, Surface::kPlain);
  shape(m, Shape::kCylinderY, -0.19f, 0.25f, 0.2f, 0.19f, 0.4f, 0.7f, c);
  shape(m, Shape::kCylinderY, -0.18f, 0.4f, 0.21f, 0.18f, 0.425f, 0.69f,
        scaled(c, 0.94f));
  return m;
}

Model ModelBuilder::bathtub() {
  Model m = start("bathtub", {"white", "white", "white", "grey"});
  const float w = rng_.uniform(1.5f, 1.7f), d = rng_.uniform(0.7f, 0.8f),
              h = 0.55f, t = 0.07f;
  m.width = w;
  m.depth = d;
  const Rgb8 c = namedColor(m.color);
  box(m, -w / 2, 0.0f, 0.0f, w / 2, h, t, c, Surface::kPlain);
  box(m, -w / 2, 0.0f, d - t, w / 2, h, d, c, Surface::kPlain);
  box(m, -w / 2, 0.0f, t, -w / 2 + t, h, d - t, c, Surface::kPlain);
  box(m, w / 2 - t, 0.0f, t, w / 2, h, d - t, c, Surface::kPlain);
  box(m, -w / 2 + t, 0.0f, t, w / 2 - t, 0.12f, d - t, scaled(c, 0.9f),
      Surface::kPlain);
  shape(m, Shape::kCylinderY, -w / 2 + 0.12f, h, 0.02f, -w / 2 + 0.16f,
        h + 0.2f, 0.06f, kSteel);
  return m;
}

Model ModelBuilder::washer() {
  Model m = start("washing machine", {"white", "white", "grey"});
  const float w = 0.6f, d = 0.6f, h = 0.85f;
  m.width = w;
  m.depth = d;
  const Rgb8 c = namedColor(m.color);
  box(m, -w / 2, 0.0f, 0.0f, w / 2, h, d - 0.03f, c, Surface::kPlain);
  shape(m, Shape::kCylinderZ, -0.2f, 0.22f, d - 0.03f, 0.2f, 0.62f, d - 0.01f,
        kMetal);
  shape(m, Shape::kCylinderZ, -0.14f, 0.28f, d - 0.01f, 0.14f, 0.56f, d,
        kScreen);
  box(m, -w / 2 + 0.03f, h - 0.12f, d - 0.03f, w / 2 - 0.03f, h - 0.03f,
      d - 0.02f, scaled(c, 0.75f), Surface::kPlain);
  return m;
}

void ModelBuilder::counterBody(Model& m, const std::string& color,
                               const std::string& topName, float w, float d,
                               float h, bool doors) {
  const Rgb8 c = namedColor(color);
  box(m, -w / 2, 0.0f, 0.0f, w / 2, 0.1f, d - 0.08f, kDark, Surface::kPlain);
  box(m, -w / 2, 0.1f, 0.0f, w / 2, h - 0.04f, d - 0.04f, c,
      finishOf(color, Surface::kPlain));
  box(m, -w / 2, h - 0.04f, 0.0f, w / 2, h, d, namedColor(topName),
      finishOf(topName, Surface::kPlain));
  if (!doors) return;
  const int count = std::max(1, static_cast<int>(w / 0.5f));
  for (int i = 1; i < count; ++i) {
    const float x = -w / 2 + w * static_cast<float>(i) / count;
    box(m, x - 0.003f, 0.12f, d - 0.04f, x + 0.003f, h - 0.06f, d - 0.035f,
        scaled(c, 0.55f), Surface::kPlain);
  }
  for (int i = 0; i < count; ++i) {
    const float x = -w / 2 + w * (static_cast<float>(i) + 0.5f) / count;
    box(m, x - 0.06f, h - 0.16f, d - 0.04f, x + 0.06f, h - 0.14f, d - 0.035f,
        kMetal, Surface::kPlain);
  }
}

}  // namespace vln::world::house
