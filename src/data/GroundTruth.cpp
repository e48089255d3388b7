#include "data/GroundTruth.h"

#include "common/Check.h"
#include "common/Json.h"
#include "data/Episode.h"

namespace vln::data {
namespace {

const nlohmann::json& arrayField(const nlohmann::json& object, const char* key,
                                 std::string_view context) {
  auto it = object.find(key);
  VLN_CHECK_ARG(it != object.end(), context, ": field '", key, "' is missing");
  VLN_CHECK_ARG(it->is_array(), context, ": field '", key,
                "' must be an array, got ", it->type_name());
  return *it;
}

void validatePath(const GroundTruthPath& path, std::string_view context) {
  for (size_t i = 0; i < path.locations.size(); ++i)
    VLN_CHECK_ARG(path.locations[i].allFinite(), context,
                  ": field 'locations' entry ", i, " is not finite");
  for (size_t i = 0; i < path.actions.size(); ++i) {
    int code = static_cast<int>(path.actions[i]);
    VLN_CHECK_ARG(code >= 0 && code < sim::kNumActions, context,
                  ": field 'actions' entry ", i, " is ", code,
                  ", not an action code in [0, ", sim::kNumActions, ")");
  }
  VLN_CHECK_ARG(path.forward_steps >= 0, context,
                ": field 'forward_steps' must be >= 0, got ",
                path.forward_steps);
}

GroundTruth parseRoot(const nlohmann::json& root, const std::string& where) {
  VLN_CHECK_ARG(root.is_object(), where,
                ": expected a JSON object keyed by episode id, got ",
                root.type_name());
  GroundTruth groundTruth;
  for (const auto& [key, entry] : root.items()) {
    const int id = episodeIdKey(key, where);
    std::string context = strCat(where, ": episode ", id);
    VLN_CHECK_ARG(entry.is_object(), context, ": expected a JSON object, got ",
                  entry.type_name());

    GroundTruthPath path;
    const auto& locations = arrayField(entry, "locations", context);
    path.locations.reserve(locations.size());
    for (size_t i = 0; i < locations.size(); ++i)
      path.locations.push_back(vec3FromJson(
          locations[i], strCat(context, ": field 'locations' entry ", i)));
    const auto& actions = arrayField(entry, "actions", context);
    path.actions.reserve(actions.size());
    for (size_t i = 0; i < actions.size(); ++i) {
      const auto& action = actions[i];
      VLN_CHECK_ARG(action.is_number_integer(), context,
                    ": field 'actions' entry ", i,
                    " must be an integer action code, got ", action.dump());
      auto code = action.get<int64_t>();
      VLN_CHECK_ARG(code >= 0 && code < sim::kNumActions, context,
                    ": field 'actions' entry ", i, " is ", code,
                    ", not an action code in [0, ", sim::kNumActions, ")");
      path.actions.push_back(static_cast<sim::Action>(code));
    }
    path.forward_steps = intField(entry, "forward_steps", context);
    validatePath(path, context);
    VLN_CHECK_ARG(groundTruth.emplace(id, std::move(path)).second, where,
                  ": episode id ", id, " appears twice (key '", key, "')");
  }
  return groundTruth;
}

}  // namespace

GroundTruth parseGroundTruth(const nlohmann::json& root,
                             std::string_view source) {
  return parseRoot(root, strCat("parseGroundTruth(): '", source, "'"));
}

GroundTruth readGroundTruth(const std::filesystem::path& file) {
  return parseRoot(common::readJsonFile(file),
                   strCat("readGroundTruth(): '", file.string(), "'"));
}

nlohmann::json groundTruthToJson(const GroundTruth& groundTruth) {
  nlohmann::json root = nlohmann::json::object();
  for (const auto& [id, path] : groundTruth) {
    nlohmann::json locations = nlohmann::json::array();
    for (const Vec3f& location : path.locations)
      locations.push_back(vec3ToJson(location));
    nlohmann::json actions = nlohmann::json::array();
    for (sim::Action action : path.actions)
      actions.push_back(static_cast<int>(action));
    root[std::to_string(id)] = {{"locations", std::move(locations)},
                                {"actions", std::move(actions)},
                                {"forward_steps", path.forward_steps}};
  }
  return root;
}

void writeGroundTruth(const std::filesystem::path& file,
                      const GroundTruth& groundTruth) {
  // validate before touching the disk so bad data leaves no file
  std::string where = strCat("writeGroundTruth(): '", file.string(), "'");
  for (const auto& [id, path] : groundTruth)
    validatePath(path, strCat(where, ": episode ", id));
  common::writeJsonFile(file, groundTruthToJson(groundTruth));
}

}  // namespace vln::data
