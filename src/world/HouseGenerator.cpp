// Procedural houses: ties the stages of HouseBuilder.h together (floor plan,
// style, furniture, textures, mesh) and holds the fixed vocabularies.

// First of all includes: no FMA contraction (see the header).
#include "world/HouseFpContract.h"

#include "world/HouseGenerator.h"

#include <algorithm>

#include "common/Check.h"
#include "world/HouseBuilder.h"

namespace vln::world {

namespace {

// Colour names with RGB a person would call by that name (sRGB, chosen by
// eye to be unambiguous under the baked lighting).
struct NamedColor {
  const char* name;
  sim::Rgb8 rgb;
};
const std::vector<NamedColor>& namedColors() {
  static const std::vector<NamedColor> colors = {
      {"red", {196, 44, 40}},     {"orange", {230, 126, 34}},
      {"yellow", {236, 200, 48}}, {"green", {64, 146, 64}},
      {"blue", {46, 92, 184}},    {"purple", {122, 62, 156}},
      {"pink", {236, 146, 178}},  {"brown", {112, 72, 42}},
      {"wooden", {178, 128, 80}}, {"white", {236, 236, 232}},
      {"grey", {130, 130, 132}},  {"black", {36, 36, 38}}};
  return colors;
}

// Stream ids of the generation stages (arbitrary distinct constants).
constexpr uint64_t kPlanStream = 1;
constexpr uint64_t kStyleStream = 2;
constexpr uint64_t kFurnitureStream = 3;
constexpr uint64_t kTextureStream = 4;

}  // namespace

const std::vector<std::string>& houseRoomTypes() {
  static const std::vector<std::string> types = {
      "living room", "kitchen", "dining room",  "bedroom", "bathroom",
      "hallway",     "office",  "laundry room", "closet"};
  return types;
}

const std::vector<std::string>& houseObjectCategories() {
  static const std::vector<std::string> categories = {
      "bed",      "nightstand",   "wardrobe",       "dresser",         "sofa",
      "armchair", "coffee table", "table",          "chair",           "tv",
      "plant",    "lamp",         "bookcase",       "shelf",           "desk",
      "cabinet",  "counter",      "kitchen island", "stove",           "fridge",
      "sink",     "toilet",       "bathtub",        "washing machine", "rug",
      "picture",  "mirror",       "piano",          "window"};
  return categories;
}

const std::vector<std::string>& houseColorNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const NamedColor& c : namedColors()) out.emplace_back(c.name);
    return out;
  }();
  return names;
}

sim::Rgb8 house::namedColor(const std::string& name) {
  for (const NamedColor& c : namedColors())
    if (name == c.name) return c.rgb;
  assertFailed(("namedColor: unknown colour " + name).c_str(), __FILE__,
               __LINE__);
}

Eigen::AlignedBox2f doorwayClearZone(const sim::Doorway& door) {
  const Vec2f center(door.center.x(), door.center.z());
  // the wall runs perpendicular to its (horizontal) normal
  const Vec2f normal = Vec2f(door.normal.x(), door.normal.z()).normalized();
  const Vec2f along(-normal.y(), normal.x());
  const float halfAlong = 0.5f * door.width + kDoorwayClearMargin;
  Eigen::AlignedBox2f zone;
  for (float a : {-halfAlong, halfAlong})
    for (float n : {-kDoorwayClearDepth, kDoorwayClearDepth})
      zone.extend(Vec2f(center + a * along + n * normal));
  return zone;
}

House generateHouse(uint64_t seed, const HouseConfig& config,
                    const std::string& name) {
  config.validate();
  HouseConfig checked = config;  // visit() is non-const
  common::checkConfig([&](common::ConfigVisitor& v) { checked.visit(v); },
                      "generateHouse(): HouseConfig");

  // independent streams per stage: tuning one stage never reshuffles another
  house::Rng root(seed, /*stream=*/0x484F555345ull);
  house::Rng planRng = root.fork(kPlanStream);
  house::Rng styleRng = root.fork(kStyleStream);
  house::Rng furnitureRng = root.fork(kFurnitureStream);
  house::Rng textureRng = root.fork(kTextureStream);

  const house::FloorPlan plan = house::planFloor(planRng, config);
  const house::HouseStyle style = house::chooseStyle(styleRng, plan);
  House out;
  out.name = name.empty() ? strCat("house_", seed) : name;
  std::vector<house::PlacedObject> objects =
      house::furnish(furnitureRng, plan, config, out.floor_holes);

  // one material per surface finish, textured unless detail is off
  sim::TriangleMesh& mesh = out.mesh;
  const bool textured = config.texture_detail > 0.0f;
  for (int s = 0; s < static_cast<int>(house::Surface::kCount); ++s) {
    const auto surface = static_cast<house::Surface>(s);
    sim::Material material;
    material.name = house::surfaceName(surface);
    if (textured && surface != house::Surface::kPlain) {
      material.texture = static_cast<int>(mesh.textures.size());
      mesh.textures.push_back(house::makeSurfaceTexture(surface, textureRng,
                                                        config.texture_detail));
    }
    mesh.materials.push_back(std::move(material));
  }

  house::MeshBuilder builder(mesh, textured);
  house::buildStructure(plan, style, config, out.floor_holes, builder);
  for (house::PlacedObject& object : objects) {
    builder.setObject(object.semantic.id);
    builder.setTint(style.rooms[object.semantic.room].tint);
    const size_t first = mesh.positions.size();
    for (const house::Part& part : object.parts) {
      // faces resting on the floor are never seen
      const unsigned skip = part.box.min().y() <= 0.0f ? (1u << 2) : 0u;
      builder.part(part, skip);
    }
    // bounds from the vertices themselves, so they match the mesh exactly
    Eigen::AlignedBox3f bounds;
    for (size_t v = first; v < mesh.positions.size(); ++v)
      bounds.extend(mesh.positions[v]);
    object.semantic.bounds = bounds;
  }

  // semantics
  for (size_t r = 0; r < plan.rooms.size(); ++r) {
    sim::Room room;
    room.id = static_cast<int>(r);
    room.type = plan.rooms[r].type;
    const house::RectCm& c = plan.rooms[r].cell;
    room.footprint = Eigen::AlignedBox2f(
        Vec2f(static_cast<float>(c.x0), static_cast<float>(c.z0)) / 100.0f,
        Vec2f(static_cast<float>(c.x1), static_cast<float>(c.z1)) / 100.0f);
    room.floor_y = 0.0f;
    out.semantics.rooms.push_back(std::move(room));
  }
  for (const house::PlanDoor& door : plan.doors)
    out.semantics.doors.push_back(house::toDoorway(door));
  for (house::PlacedObject& object : objects)
    out.semantics.objects.push_back(std::move(object.semantic));

  mesh.validate(strCat("generateHouse(", out.name, ")"));
  return out;
}

}  // namespace vln::world
