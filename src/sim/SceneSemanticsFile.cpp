#include "sim/SceneSemanticsFile.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "common/Check.h"
#include "common/Json.h"

namespace vln::sim {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

json vecJson(const Vec3f& v) { return {v.x(), v.y(), v.z()}; }

template <int N>
Eigen::Matrix<float, N, 1> readVec(const json& object, std::string_view key,
                                   const std::string& context) {
  const auto values =
      common::requireField<std::vector<float>>(object, key, context);
  VLN_CHECK_ARG(values.size() == N, context, ": field '", key, "' needs ", N,
                " numbers, got ", values.size());
  Eigen::Matrix<float, N, 1> v;
  for (int i = 0; i < N; ++i) {
    VLN_CHECK_ARG(std::isfinite(values[i]), context, ": field '", key,
                  "' has a non-finite value");
    v[i] = values[i];
  }
  return v;
}

// {"min": [..], "max": [..]} with min <= max
template <int N>
Eigen::AlignedBox<float, N> readBox(const json& object, std::string_view key,
                                    const std::string& context) {
  const auto box = common::requireField<json>(object, key, context);
  const std::string inner = strCat(context, ".", key);
  Eigen::AlignedBox<float, N> out(readVec<N>(box, "min", inner),
                                  readVec<N>(box, "max", inner));
  VLN_CHECK_ARG((out.min().array() <= out.max().array()).all(), inner,
                ": min exceeds max");
  return out;
}

template <class Box>
json boxJson(const Box& box) {
  json lo = json::array(), hi = json::array();
  for (int i = 0; i < box.dim(); ++i) {
    lo.push_back(box.min()[i]);
    hi.push_back(box.max()[i]);
  }
  return {{"min", lo}, {"max", hi}};
}

json requireArray(const json& root, std::string_view key,
                  const std::string& context) {
  const auto value = common::requireField<json>(root, key, context);
  VLN_CHECK_ARG(value.is_array(), context, ": field '", key,
                "' must be an array, got ", value.type_name());
  return value;
}

}  // namespace

fs::path semanticsPath(const fs::path& sceneFile) {
  return fs::path(sceneFile.string() + ".semantics.json");
}

SceneSemantics loadSemantics(const fs::path& file) {
  const json root = common::readJsonFile(file);
  const std::string source = file.string();
  SceneSemantics semantics;

  const json rooms = requireArray(root, "rooms", source);
  for (size_t i = 0; i < rooms.size(); ++i) {
    const std::string context = strCat(source, ": rooms[", i, "]");
    Room room;
    room.id = common::requireField<int>(rooms[i], "id", context);
    room.type = common::requireField<std::string>(rooms[i], "type", context);
    room.footprint = readBox<2>(rooms[i], "footprint", context);
    room.floor_y = common::requireField<float>(rooms[i], "floor_y", context);
    semantics.rooms.push_back(std::move(room));
  }

  const json doors = requireArray(root, "doors", source);
  for (size_t i = 0; i < doors.size(); ++i) {
    const std::string context = strCat(source, ": doors[", i, "]");
    Doorway door;
    door.room_a = common::requireField<int>(doors[i], "room_a", context);
    door.room_b = common::requireField<int>(doors[i], "room_b", context);
    door.center = readVec<3>(doors[i], "center", context);
    door.width = common::requireField<float>(doors[i], "width", context);
    VLN_CHECK_ARG(door.width > 0.0f, context,
                  ": field 'width' must be > 0, got ", door.width);
    door.normal = readVec<3>(doors[i], "normal", context);
    semantics.doors.push_back(door);
  }

  const json objects = requireArray(root, "objects", source);
  std::set<int> ids;
  for (size_t i = 0; i < objects.size(); ++i) {
    const std::string context = strCat(source, ": objects[", i, "]");
    SemanticObject object;
    object.id = common::requireField<int>(objects[i], "id", context);
    VLN_CHECK_ARG(object.id >= 0, context, ": field 'id' must be >= 0, got ",
                  object.id);
    VLN_CHECK_ARG(ids.insert(object.id).second, context,
                  ": field 'id' repeats id ", object.id);
    object.category =
        common::requireField<std::string>(objects[i], "category", context);
    object.color =
        common::requireField<std::string>(objects[i], "color", context);
    object.room = common::requireField<int>(objects[i], "room", context);
    object.bounds = readBox<3>(objects[i], "bounds", context);
    semantics.objects.push_back(std::move(object));
  }

  // room references must resolve
  std::set<int> roomIds;
  for (const Room& room : semantics.rooms) roomIds.insert(room.id);
  auto checkRoom = [&](int room, const std::string& context,
                       std::string_view field) {
    VLN_CHECK_ARG(room == -1 || roomIds.count(room) > 0, context, ": field '",
                  field, "' names room ", room, " which is not in 'rooms'");
  };
  for (size_t i = 0; i < semantics.doors.size(); ++i) {
    checkRoom(semantics.doors[i].room_a, strCat(source, ": doors[", i, "]"),
              "room_a");
    checkRoom(semantics.doors[i].room_b, strCat(source, ": doors[", i, "]"),
              "room_b");
  }
  for (size_t i = 0; i < semantics.objects.size(); ++i)
    checkRoom(semantics.objects[i].room, strCat(source, ": objects[", i, "]"),
              "room");
  return semantics;
}

void saveSemantics(const fs::path& file, const SceneSemantics& semantics) {
  json rooms = json::array();
  for (const Room& room : semantics.rooms)
    rooms.push_back({{"id", room.id},
                     {"type", room.type},
                     {"footprint", boxJson(room.footprint)},
                     {"floor_y", room.floor_y}});
  json doors = json::array();
  for (const Doorway& door : semantics.doors)
    doors.push_back({{"room_a", door.room_a},
                     {"room_b", door.room_b},
                     {"center", vecJson(door.center)},
                     {"width", door.width},
                     {"normal", vecJson(door.normal)}});
  json objects = json::array();
  for (const SemanticObject& object : semantics.objects)
    objects.push_back({{"id", object.id},
                       {"category", object.category},
                       {"color", object.color},
                       {"room", object.room},
                       {"bounds", boxJson(object.bounds)}});
  common::writeJsonFile(
      file, {{"rooms", rooms}, {"doors", doors}, {"objects", objects}},
      /*indent=*/1);
}

}  // namespace vln::sim
