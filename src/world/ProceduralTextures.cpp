// Appearance of procedural houses: per-room styles (wall, floor and light
// colours by room type) and the small tileable textures of each surface
// finish. Textures are near-white patterns that multiply the baked vertex
// colours, so one texture per finish serves every room of a house.

// First of all includes: no FMA contraction (see the header).
#include "world/HouseFpContract.h"

#include <algorithm>
#include <cmath>

#include "common/Check.h"
#include "common/Random.h"
#include "world/HouseBuilder.h"

namespace vln::world::house {

// ===========================================================================
// surfaces
// ===========================================================================

float surfacePeriod(Surface surface) {
  // metres covered by one texture repeat (plank, tile and stripe sizes of
  // ordinary interiors: 20 cm planks, 30 cm tiles, 6 cm stripes)
  switch (surface) {
    case Surface::kWoodFloor:
      return 1.6f;
    case Surface::kTiles:
      return 0.6f;
    case Surface::kCarpet:
      return 0.5f;
    case Surface::kWallpaper:
      return 0.5f;
    case Surface::kPlaster:
      return 1.2f;
    case Surface::kWood:
      return 0.6f;
    case Surface::kFabric:
      return 0.25f;
    default:
      return 1.0f;
  }
}

const char* surfaceName(Surface surface) {
  switch (surface) {
    case Surface::kPlain:
      return "plain";
    case Surface::kWoodFloor:
      return "wood_floor";
    case Surface::kTiles:
      return "tiles";
    case Surface::kCarpet:
      return "carpet";
    case Surface::kWallpaper:
      return "wallpaper";
    case Surface::kPlaster:
      return "plaster";
    case Surface::kWood:
      return "wood";
    case Surface::kFabric:
      return "fabric";
    default:
      return "unknown";
  }
}

// ===========================================================================
// room styles
// ===========================================================================

namespace {

Rgb8 pick(Rng& rng, const std::vector<Rgb8>& colors) {
  return colors[rng.intIn(0, static_cast<int>(colors.size()) - 1)];
}

// Paint colours of real interiors, light to mid tones.
const std::vector<Rgb8> kWallPaints = {
    {236, 233, 224}, {224, 212, 186}, {208, 208, 202}, {192, 210, 224},
    {202, 220, 192}, {238, 228, 176}, {232, 204, 198}, {216, 198, 164},
    {210, 202, 224}, {198, 228, 212}, {222, 176, 146}, {160, 178, 196}};
const std::vector<Rgb8> kBathroomPaints = {{240, 240, 236},
                                           {200, 222, 232},
                                           {214, 232, 220},
                                           {232, 228, 214},
                                           {190, 204, 214}};
const std::vector<Rgb8> kWoodFloors = {{200, 160, 112}, {124, 88, 58},
                                       {184, 134, 84},  {154, 144, 134},
                                       {218, 186, 142}, {150, 100, 64}};
const std::vector<Rgb8> kTileFloors = {{232, 232, 228}, {172, 172, 170},
                                       {212, 198, 172}, {178, 100, 74},
                                       {142, 162, 178}, {96, 96, 100}};
const std::vector<Rgb8> kCarpets = {{192, 178, 152}, {142, 142, 142},
                                    {94, 112, 142},  {112, 132, 102},
                                    {172, 124, 124}, {120, 100, 84}};
const std::vector<Rgb8> kCeilings = {
    {242, 242, 238}, {236, 234, 226}, {246, 244, 240}};
const std::vector<Rgb8> kTrims = {
    {244, 244, 240}, {236, 232, 222}, {160, 116, 76}, {90, 70, 56}};
const std::vector<Rgb8> kExteriors = {
    {210, 204, 192}, {186, 170, 150}, {200, 200, 204}, {170, 120, 96}};

}  // namespace

HouseStyle chooseStyle(Rng& rng, const FloorPlan& plan) {
  HouseStyle house;
  house.exterior = pick(rng, kExteriors);
  // a house-wide trim and ceiling, as builders do
  const Rgb8 trim = pick(rng, kTrims);
  const Rgb8 ceiling = pick(rng, kCeilings);
  // one light temperature per house, jittered per room
  const std::array<std::array<float, 3>, 3> temperatures = {
      {{1.0f, 0.96f, 0.88f}, {1.0f, 1.0f, 1.0f}, {0.94f, 0.97f, 1.0f}}};
  const auto houseLight = temperatures[rng.intIn(0, 2)];

  for (const PlanRoom& room : plan.rooms) {
    const std::string& type = room.type;
    RoomStyle style;
    style.trim = trim;
    style.ceiling = ceiling;
    const bool wet = type == "bathroom" || type == "laundry room";
    const bool kitchen = type == "kitchen";

    // walls: paint, wallpaper in living spaces, tiles in wet rooms
    style.wall = pick(rng, wet ? kBathroomPaints : kWallPaints);
    if (wet)
      style.wall_surface =
          rng.chance(0.7f) ? Surface::kTiles : Surface::kPlaster;
    else if (kitchen)
      style.wall_surface =
          rng.chance(0.3f) ? Surface::kTiles : Surface::kPlaster;
    else
      style.wall_surface =
          rng.chance(0.3f) ? Surface::kWallpaper : Surface::kPlaster;

    // floors by room type: (wood, tiles, carpet) weights
    std::vector<float> weights{0.6f, 0.2f, 0.2f};
    if (wet) weights = {0.0f, 1.0f, 0.0f};
    if (kitchen) weights = {0.25f, 0.75f, 0.0f};
    if (type == "bedroom" || type == "closet") weights = {0.5f, 0.0f, 0.5f};
    if (type == "office") weights = {0.6f, 0.0f, 0.4f};
    if (type == "hallway") weights = {0.6f, 0.4f, 0.0f};
    if (type == "dining room") weights = {0.8f, 0.2f, 0.0f};
    switch (rng.weighted(weights)) {
      case 0:
        style.floor_surface = Surface::kWoodFloor;
        style.floor = pick(rng, kWoodFloors);
        break;
      case 1:
        style.floor_surface = Surface::kTiles;
        style.floor = pick(rng, kTileFloors);
        break;
      default:
        style.floor_surface = Surface::kCarpet;
        style.floor = pick(rng, kCarpets);
        break;
    }
    const float brightness = rng.uniform(0.95f, 1.05f);
    for (int k = 0; k < 3; ++k) style.tint[k] = houseLight[k] * brightness;
    house.rooms.push_back(style);
  }
  return house;
}

// ===========================================================================
// procedural textures
// ===========================================================================

namespace {

// hash of a lattice point to [0, 1)
float latticeValue(int x, int y, uint64_t seed) {
  const uint64_t h =
      common::mixBits(seed ^ (static_cast<uint64_t>(static_cast<uint32_t>(x)) << 32) ^
            static_cast<uint32_t>(y));
  return static_cast<float>(h >> 40) * (1.0f / 16777216.0f);
}

// Smooth value noise in [0, 1) over a lattice that repeats every `period`
// cells, so textures built from it tile seamlessly.
float valueNoise(float x, float y, int period, uint64_t seed) {
  const float fx = std::floor(x), fy = std::floor(y);
  const float tx = x - fx, ty = y - fy;
  const int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
  auto wrap = [period](int i) { return ((i % period) + period) % period; };
  const float v00 = latticeValue(wrap(ix), wrap(iy), seed);
  const float v10 = latticeValue(wrap(ix + 1), wrap(iy), seed);
  const float v01 = latticeValue(wrap(ix), wrap(iy + 1), seed);
  const float v11 = latticeValue(wrap(ix + 1), wrap(iy + 1), seed);
  const float sx = tx * tx * (3.0f - 2.0f * tx);
  const float sy = ty * ty * (3.0f - 2.0f * ty);
  const float a = v00 + (v10 - v00) * sx;
  const float b = v01 + (v11 - v01) * sx;
  return a + (b - a) * sy;
}

class Canvas {
 public:
  Canvas(int size, float detail)
      : size_(size), detail_(detail), value_(size * size, 1.0f) {}
  int size() const { return size_; }
  float& at(int x, int y) { return value_[static_cast<size_t>(y) * size_ + x]; }

  // pattern value 1 is white; `detail` scales how far darker values reach
  Texture finish(const char* name) const {
    Texture texture;
    texture.name = name;
    texture.width = size_;
    texture.height = size_;
    texture.rgb.resize(static_cast<size_t>(size_) * size_ * 3);
    for (size_t i = 0; i < value_.size(); ++i) {
      const float v =
          1.0f - detail_ * (1.0f - std::clamp(value_[i], 0.0f, 1.0f));
      const auto byte =
          static_cast<uint8_t>(std::clamp(v * 255.0f + 0.5f, 0.0f, 255.0f));
      texture.rgb[3 * i] = texture.rgb[3 * i + 1] = texture.rgb[3 * i + 2] =
          byte;
    }
    return texture;
  }

 private:
  int size_;
  float detail_;
  std::vector<float> value_;
};

// Planks 16 px (20 cm) wide running along u, with end joints, per-plank
// tone and a stretched grain.
Texture woodFloor(Rng& rng, float detail) {
  Canvas c(128, detail);
  const uint64_t seed = rng.next64();
  constexpr int kPlank = 16;
  for (int row = 0; row < c.size() / kPlank; ++row) {
    // one or two joints per row, at random offsets
    const int joints = rng.intIn(1, 2);
    std::vector<int> cuts;
    const int first = rng.intIn(0, c.size() - 1);
    for (int j = 0; j < joints; ++j)
      cuts.push_back((first + j * c.size() / joints) % c.size());
    std::sort(cuts.begin(), cuts.end());
    std::vector<float> tone(cuts.size());
    for (float& t : tone) t = rng.uniform(0.8f, 1.0f);
    for (int y = row * kPlank; y < (row + 1) * kPlank; ++y) {
      for (int x = 0; x < c.size(); ++x) {
        // which plank segment x lies in (segments wrap around)
        size_t segment = cuts.size() - 1;
        for (size_t j = 0; j < cuts.size(); ++j)
          if (x >= cuts[j]) segment = j;
        float v = tone[segment];
        v += 0.12f * (valueNoise(x / 16.0f, y * 0.75f, 8, seed + row) - 0.5f);
        if (y == row * kPlank) v *= 0.62f;  // gap between planks
        for (int cut : cuts)
          if (x == cut) v *= 0.68f;  // plank end joint
        c.at(x, y) = v;
      }
    }
  }
  return c.finish(surfaceName(Surface::kWoodFloor));
}

// 2 x 2 tiles (30 cm) with grout lines and a slight per-tile tone.
Texture tiles(Rng& rng, float detail) {
  Canvas c(64, detail);
  const uint64_t seed = rng.next64();
  const float grout = rng.uniform(0.55f, 0.75f);
  float tone[2][2];
  for (auto& row : tone)
    for (float& t : row) t = rng.uniform(0.9f, 1.0f);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      const bool line = x % 32 < 2 || y % 32 < 2;
      c.at(x, y) =
          line ? grout
               : tone[y / 32][x / 32] +
                     0.05f * (valueNoise(x / 8.0f, y / 8.0f, 8, seed) - 0.5f);
    }
  return c.finish(surfaceName(Surface::kTiles));
}

// Fine fibre noise over a soft mottling.
Texture carpet(Rng& rng, float detail) {
  Canvas c(64, detail);
  const uint64_t seed = rng.next64();
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x)
      c.at(x, y) = 0.9f +
                   0.08f * (valueNoise(x / 16.0f, y / 16.0f, 4, seed) - 0.5f) +
                   0.08f * (latticeValue(x, y, seed + 1) - 0.5f);
  return c.finish(surfaceName(Surface::kCarpet));
}

// Vertical stripes (u runs along the wall) with thin pinstripes.
Texture wallpaper(Rng& rng, float detail) {
  Canvas c(64, detail);
  const int stripes = rng.chance(0.5f) ? 4 : 8;
  const int width = 64 / stripes;
  const float dark = rng.uniform(0.82f, 0.92f);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      const int within = x % width;
      float v = (x / width) % 2 == 0 ? 1.0f : dark;
      if (within == 0) v *= 0.85f;
      c.at(x, y) = v;
    }
  return c.finish(surfaceName(Surface::kWallpaper));
}

// Low-frequency unevenness of painted plaster.
Texture plaster(Rng& rng, float detail) {
  Canvas c(64, detail);
  const uint64_t seed = rng.next64();
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x)
      c.at(x, y) =
          0.96f + 0.035f * (valueNoise(x / 16.0f, y / 16.0f, 4, seed) - 0.5f) +
          0.015f * (valueNoise(x / 4.0f, y / 4.0f, 16, seed + 7) - 0.5f);
  return c.finish(surfaceName(Surface::kPlaster));
}

// Furniture wood: growth rings as a triangle wave bent by noise.
Texture wood(Rng& rng, float detail) {
  Canvas c(64, detail);
  const uint64_t seed = rng.next64();
  const int rings = rng.intIn(5, 8);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      const float f = static_cast<float>(y * rings) / 64.0f +
                      1.5f * valueNoise(x / 16.0f, y / 16.0f, 4, seed);
      const float frac = f - std::floor(f);
      c.at(x, y) = 0.8f + 0.2f * std::abs(2.0f * frac - 1.0f);
    }
  return c.finish(surfaceName(Surface::kWood));
}

// A basket weave of 2-pixel threads.
Texture fabric(Rng& rng, float detail) {
  Canvas c(64, detail);
  const uint64_t seed = rng.next64();
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      const bool over = ((x / 2) + (y / 2)) % 2 == 0;
      c.at(x, y) =
          (over ? 1.0f : 0.9f) + 0.04f * (latticeValue(x, y, seed) - 0.5f);
    }
  return c.finish(surfaceName(Surface::kFabric));
}

}  // namespace

Texture makeSurfaceTexture(Surface surface, Rng& rng, float detail) {
  switch (surface) {
    case Surface::kWoodFloor:
      return woodFloor(rng, detail);
    case Surface::kTiles:
      return tiles(rng, detail);
    case Surface::kCarpet:
      return carpet(rng, detail);
    case Surface::kWallpaper:
      return wallpaper(rng, detail);
    case Surface::kPlaster:
      return plaster(rng, detail);
    case Surface::kWood:
      return wood(rng, detail);
    case Surface::kFabric:
      return fabric(rng, detail);
    default:
      break;
  }
  assertFailed("makeSurfaceTexture: the plain surface has no texture", __FILE__,
               __LINE__);
}

}  // namespace vln::world::house
