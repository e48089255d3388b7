#include "data/Episode.h"

#include <charconv>
#include <cmath>
#include <limits>
#include <unordered_set>

#include "common/Check.h"
#include "common/FileIo.h"
#include "common/Json.h"

namespace vln::data {
namespace {

// =========================================================================
// strict field readers: nlohmann's get<int>() silently truncates floats, so
// every type is checked explicitly
// =========================================================================

const nlohmann::json& member(const nlohmann::json& object, const char* key,
                             std::string_view context) {
  VLN_CHECK_ARG(object.is_object(), context, ": expected a JSON object, got ",
                object.type_name());
  auto it = object.find(key);
  VLN_CHECK_ARG(it != object.end(), context, ": field '", key, "' is missing");
  return *it;
}

// an id: a JSON integer or a string holding a decimal integer (VLN-CE casts
// ids with str() and int(), so both spellings occur)
int64_t idValue(const nlohmann::json& value, std::string_view context) {
  if (value.is_string()) {
    const auto& text = value.get_ref<const std::string&>();
    int64_t id = 0;
    auto [end, error] =
        std::from_chars(text.data(), text.data() + text.size(), id);
    VLN_CHECK_ARG(!text.empty() && error == std::errc() &&
                      end == text.data() + text.size(),
                  context,
                  " must be an integer or a decimal string, got string \"",
                  text.substr(0, 40), "\"");
    return id;
  }
  VLN_CHECK_ARG(value.is_number_integer(), context, " must be an integer, got ",
                value.type_name(), " ", value.dump());
  return value.get<int64_t>();
}

int intId(const nlohmann::json& value, std::string_view context) {
  const int64_t v = idValue(value, context);
  VLN_CHECK_ARG(v >= std::numeric_limits<int>::min() &&
                    v <= std::numeric_limits<int>::max(),
                context, " is out of the int range, got ", v);
  return static_cast<int>(v);
}

int intValue(const nlohmann::json& value, std::string_view context) {
  VLN_CHECK_ARG(value.is_number_integer(), context, " must be an integer, got ",
                value.type_name(), " ", value.dump());
  auto v = value.get<int64_t>();
  VLN_CHECK_ARG(v >= std::numeric_limits<int>::min() &&
                    v <= std::numeric_limits<int>::max(),
                context, " is out of the int range, got ", v);
  return static_cast<int>(v);
}

float floatValue(const nlohmann::json& value, std::string_view context) {
  VLN_CHECK_ARG(value.is_number(), context, " must be a number, got ",
                value.type_name(), " ", value.dump());
  auto v = value.get<double>();
  VLN_CHECK_ARG(
      std::isfinite(v) && std::abs(v) <= std::numeric_limits<float>::max(),
      context, " must be a finite float, got ", v);
  return static_cast<float>(v);
}

std::string stringValue(const nlohmann::json& value, std::string_view context) {
  VLN_CHECK_ARG(value.is_string(), context, " must be a string, got ",
                value.type_name(), " ", value.dump());
  return value.get<std::string>();
}

const nlohmann::json& arrayValue(const nlohmann::json& value,
                                 std::string_view context) {
  VLN_CHECK_ARG(value.is_array(), context, " must be an array, got ",
                value.type_name(), " ", value.dump().substr(0, 80));
  return value;
}

std::string fieldName(std::string_view context, std::string_view key) {
  return strCat(context, ": field '", key, "'");
}

std::vector<Vec3f> vec3List(const nlohmann::json& value,
                            std::string_view context) {
  const auto& list = arrayValue(value, context);
  std::vector<Vec3f> points;
  points.reserve(list.size());
  for (size_t i = 0; i < list.size(); ++i)
    points.push_back(vec3FromJson(list[i], strCat(context, " entry ", i)));
  return points;
}

bool isFinite(const Vec3f& v) { return v.allFinite(); }

nlohmann::json floatArray(const float* values, size_t count) {
  nlohmann::json array = nlohmann::json::array();
  for (size_t i = 0; i < count; ++i)
    array.push_back(static_cast<double>(values[i]));
  return array;
}

// a timestamp of timed_instruction: absent, null (NaN in the Python file)
// or a finite number of seconds
std::optional<double> timeValue(const nlohmann::json& word, const char* key,
                                std::string_view context) {
  auto it = word.find(key);
  if (it == word.end() || it->is_null()) return std::nullopt;
  VLN_CHECK_ARG(it->is_number(), context, ": field '", key,
                "' must be a number of seconds, got ", it->type_name(), " ",
                it->dump().substr(0, 40));
  return it->get<double>();
}

// the RxR_VLNCE_v0 fields of `instruction`, each optional
void readRxrInstruction(const nlohmann::json& instruction,
                        const std::string& where, Instruction& out) {
  if (auto id = instruction.find("instruction_id");
      id != instruction.end() && !id->is_null())
    out.instruction_id =
        idValue(*id, fieldName(where, "instruction.instruction_id"));
  if (auto language = instruction.find("language");
      language != instruction.end() && !language->is_null()) {
    out.language =
        stringValue(*language, fieldName(where, "instruction.language"));
    VLN_CHECK_ARG(!out.language.empty(), where,
                  ": field 'instruction.language' is empty");
  }
  if (auto annotator = instruction.find("annotator_id");
      annotator != instruction.end() && !annotator->is_null()) {
    if (annotator->is_number_integer())
      out.annotator_id = std::to_string(annotator->get<int64_t>());
    else
      out.annotator_id =
          stringValue(*annotator, fieldName(where, "instruction.annotator_id"));
  }
  if (auto distance = instruction.find("edit_distance");
      distance != instruction.end() && !distance->is_null()) {
    std::string context = fieldName(where, "instruction.edit_distance");
    VLN_CHECK_ARG(distance->is_number(), context, " must be a number, got ",
                  distance->type_name(), " ", distance->dump().substr(0, 40));
    out.edit_distance = distance->get<double>();
  }
  if (auto timed = instruction.find("timed_instruction");
      timed != instruction.end() && !timed->is_null()) {
    std::string context = fieldName(where, "instruction.timed_instruction");
    const auto& list = arrayValue(*timed, context);
    out.timed_instruction.reserve(list.size());
    for (size_t w = 0; w < list.size(); ++w) {
      std::string wordContext = strCat(context, " entry ", w);
      TimedWord word;
      word.word = stringValue(member(list[w], "word", wordContext),
                              strCat(wordContext, ": field 'word'"));
      word.start_time = timeValue(list[w], "start_time", wordContext);
      word.end_time = timeValue(list[w], "end_time", wordContext);
      out.timed_instruction.push_back(std::move(word));
    }
  }
}

// Python's json module writes NaN and +-Infinity as bare tokens, which are
// not JSON; outside strings they become null (RxR's timed_instruction has
// NaN times)
std::string nullNonFiniteTokens(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  bool inString = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (inString) {
      out += c;
      if (c == '\\' && i + 1 < text.size())
        out += text[++i];
      else if (c == '"')
        inString = false;
      continue;
    }
    if (c == '"') inString = true;
    bool replaced = false;
    for (std::string_view token : {"NaN", "Infinity", "-Infinity"}) {
      if (text.compare(i, token.size(), token) == 0) {
        out += "null";
        i += token.size() - 1;
        replaced = true;
        break;
      }
    }
    if (!replaced) out += c;
  }
  return out;
}

// the parser shared by readEpisodes() and parseEpisodes(); `where` names
// the function and the source in every message
EpisodeDataset parseRoot(const nlohmann::json& root, const std::string& where) {
  VLN_CHECK_ARG(root.is_object(), where,
                ": expected a JSON object with 'episodes', got ",
                root.type_name());
  EpisodeDataset dataset;
  if (auto vocab = root.find("instruction_vocab"); vocab != root.end())
    dataset.instruction_vocab =
        Vocabulary::fromJson(*vocab, strCat(where, ": instruction_vocab"));
  const auto& episodes =
      arrayValue(member(root, "episodes", where), fieldName(where, "episodes"));

  const Vocabulary* vocab =
      dataset.instruction_vocab ? &*dataset.instruction_vocab : nullptr;
  std::unordered_set<int> seen;
  dataset.episodes.reserve(episodes.size());
  for (size_t i = 0; i < episodes.size(); ++i) {
    Episode episode = episodeFromJson(episodes[i], where, i);
    std::string context = strCat(where, ": episode ", episode.episode_id);
    validateEpisode(episode, vocab, context);
    VLN_CHECK_ARG(seen.insert(episode.episode_id).second, context,
                  ": field 'episode_id' is duplicated (episode index ", i, ")");
    dataset.episodes.push_back(std::move(episode));
  }
  return dataset;
}

}  // namespace

// =========================================================================
// reading
// =========================================================================

Vec3f vec3FromJson(const nlohmann::json& value, std::string_view context) {
  VLN_CHECK_ARG(value.is_array() && value.size() == 3, context,
                " must be an [x, y, z] array, got ",
                value.dump().substr(0, 80));
  return {floatValue(value[0], context), floatValue(value[1], context),
          floatValue(value[2], context)};
}

int episodeIdKey(std::string_view key, std::string_view context) {
  int id = 0;
  auto [end, error] = std::from_chars(key.data(), key.data() + key.size(), id);
  VLN_CHECK_ARG(
      error == std::errc() && end == key.data() + key.size() && !key.empty(),
      context, ": key '", key, "' is not an integer episode id");
  return id;
}

int intField(const nlohmann::json& object, std::string_view key,
             std::string_view context) {
  auto it = object.find(key);
  VLN_CHECK_ARG(it != object.end(), context, ": field '", key, "' is missing");
  VLN_CHECK_ARG(it->is_number_integer(), context, ": field '", key,
                "' must be an integer, got ", it->type_name(), " ",
                it->dump().substr(0, 80));
  auto value = it->get<int64_t>();
  VLN_CHECK_ARG(value >= std::numeric_limits<int>::min() &&
                    value <= std::numeric_limits<int>::max(),
                context, ": field '", key, "' is out of the int range, got ",
                value);
  return static_cast<int>(value);
}

nlohmann::json vec3ToJson(const Vec3f& v) { return floatArray(v.data(), 3); }

Episode episodeFromJson(const nlohmann::json& value, std::string_view source,
                        size_t index) {
  Episode episode;
  std::string indexed = strCat(source, ": episode index ", index);
  episode.episode_id = intId(member(value, "episode_id", indexed),
                             fieldName(indexed, "episode_id"));
  // from here on the episode is named by its id, which users can grep for
  std::string where = strCat(source, ": episode ", episode.episode_id);

  episode.trajectory_id = intId(member(value, "trajectory_id", where),
                                fieldName(where, "trajectory_id"));
  episode.scene_id = stringValue(member(value, "scene_id", where),
                                 fieldName(where, "scene_id"));
  episode.start_position = vec3FromJson(member(value, "start_position", where),
                                        fieldName(where, "start_position"));
  const auto& rotation = member(value, "start_rotation", where);
  VLN_CHECK_ARG(rotation.is_array() && rotation.size() == 4, where,
                ": field 'start_rotation' must be an [x, y, z, w] array, got ",
                rotation.dump().substr(0, 80));
  for (size_t k = 0; k < 4; ++k)
    episode.start_rotation[k] =
        floatValue(rotation[k], fieldName(where, "start_rotation"));

  // optional in the test split
  if (auto info = value.find("info"); info != value.end() && !info->is_null())
    episode.geodesic_distance =
        floatValue(member(*info, "geodesic_distance", strCat(where, ": info")),
                   fieldName(where, "info.geodesic_distance"));
  if (auto goals = value.find("goals"); goals != value.end()) {
    const auto& list = arrayValue(*goals, fieldName(where, "goals"));
    for (size_t g = 0; g < list.size(); ++g) {
      std::string goalContext = strCat(where, ": goals[", g, "]");
      Goal goal;
      goal.position = vec3FromJson(member(list[g], "position", goalContext),
                                   fieldName(goalContext, "position"));
      if (auto radius = list[g].find("radius");
          radius != list[g].end() && !radius->is_null())
        goal.radius = floatValue(*radius, fieldName(goalContext, "radius"));
      episode.goals.push_back(goal);
    }
  }
  if (auto path = value.find("reference_path"); path != value.end())
    episode.reference_path =
        vec3List(*path, fieldName(where, "reference_path"));

  const auto& instruction = member(value, "instruction", where);
  std::string instructionContext = strCat(where, ": instruction");
  episode.instruction.instruction_text =
      stringValue(member(instruction, "instruction_text", instructionContext),
                  fieldName(where, "instruction.instruction_text"));
  if (auto tokens = instruction.find("instruction_tokens");
      tokens != instruction.end()) {
    std::string tokenContext =
        fieldName(where, "instruction.instruction_tokens");
    const auto& list = arrayValue(*tokens, tokenContext);
    episode.instruction.instruction_tokens.reserve(list.size());
    for (size_t t = 0; t < list.size(); ++t)
      episode.instruction.instruction_tokens.push_back(
          intValue(list[t], strCat(tokenContext, " entry ", t)));
  }
  readRxrInstruction(instruction, where, episode.instruction);
  return episode;
}

void validateEpisode(const Episode& episode, const Vocabulary* vocabulary,
                     std::string_view context) {
  VLN_CHECK_ARG(!episode.scene_id.empty(), context,
                ": field 'scene_id' is empty");
  VLN_CHECK_ARG(isFinite(episode.start_position), context,
                ": field 'start_position' is not finite");

  // Habitat agents only rotate about +Y, so any tilt means a corrupt file
  const auto& q = episode.start_rotation;
  float norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  VLN_CHECK_ARG(std::isfinite(norm) &&
                    std::abs(norm - 1.0f) <= kQuaternionTolerance &&
                    std::abs(q[0]) <= kQuaternionTolerance &&
                    std::abs(q[2]) <= kQuaternionTolerance,
                context,
                ": field 'start_rotation' is not a unit yaw-only quaternion "
                "[x, y, z, w] (x = z = 0, |q| = 1), got [",
                q[0], ", ", q[1], ", ", q[2], ", ", q[3], "]");

  if (episode.geodesic_distance)
    VLN_CHECK_ARG(std::isfinite(*episode.geodesic_distance) &&
                      *episode.geodesic_distance >= 0.0f,
                  context,
                  ": field 'info.geodesic_distance' must be a "
                  "finite distance >= 0, got ",
                  *episode.geodesic_distance);
  for (size_t g = 0; g < episode.goals.size(); ++g) {
    const Goal& goal = episode.goals[g];
    VLN_CHECK_ARG(isFinite(goal.position), context, ": field 'goals[", g,
                  "].position' is not finite");
    VLN_CHECK_ARG(std::isfinite(goal.radius) && goal.radius > 0.0f, context,
                  ": field 'goals[", g, "].radius' must be > 0, got ",
                  goal.radius);
  }
  for (size_t p = 0; p < episode.reference_path.size(); ++p)
    VLN_CHECK_ARG(isFinite(episode.reference_path[p]), context,
                  ": field 'reference_path' entry ", p, " is not finite");

  // the RxR fields
  const Instruction& in = episode.instruction;
  if (in.instruction_id)
    VLN_CHECK_ARG(*in.instruction_id >= 0, context,
                  ": field 'instruction.instruction_id' must be >= 0, got ",
                  *in.instruction_id);
  if (in.edit_distance)
    VLN_CHECK_ARG(std::isfinite(*in.edit_distance), context,
                  ": field 'instruction.edit_distance' is not finite");
  for (size_t w = 0; w < in.timed_instruction.size(); ++w) {
    const TimedWord& word = in.timed_instruction[w];
    VLN_CHECK_ARG((!word.start_time || std::isfinite(*word.start_time)) &&
                      (!word.end_time || std::isfinite(*word.end_time)),
                  context, ": field 'instruction.timed_instruction' entry ", w,
                  " has a non-finite time");
  }

  const auto& tokens = episode.instruction.instruction_tokens;
  int limit = vocabulary ? vocabulary->size() : std::numeric_limits<int>::max();
  for (size_t t = 0; t < tokens.size(); ++t)
    VLN_CHECK_ARG(tokens[t] >= 0 && tokens[t] < limit, context,
                  ": field 'instruction.instruction_tokens' entry ", t, " is ",
                  tokens[t], ", outside the vocabulary [0, ",
                  vocabulary ? std::to_string(limit) : std::string("inf"), ")");
}

EpisodeDataset parseEpisodes(const nlohmann::json& root,
                             std::string_view source) {
  return parseRoot(root, strCat("parseEpisodes(): '", source, "'"));
}

EpisodeDataset readEpisodes(const std::filesystem::path& file) {
  return parseRoot(
      common::parseJson(nullNonFiniteTokens(common::readFile(file)),
                        file.string()),
      strCat("readEpisodes(): '", file.string(), "'"));
}

// =========================================================================
// writing
// =========================================================================

nlohmann::json episodeToJson(const Episode& episode) {
  nlohmann::json value = {
      {"episode_id", episode.episode_id},
      {"trajectory_id", episode.trajectory_id},
      {"scene_id", episode.scene_id},
      {"start_position", vec3ToJson(episode.start_position)},
      {"start_rotation", floatArray(episode.start_rotation.data(), 4)},
  };
  if (episode.geodesic_distance)
    value["info"] = {
        {"geodesic_distance", static_cast<double>(*episode.geodesic_distance)}};
  if (!episode.goals.empty()) {
    nlohmann::json goals = nlohmann::json::array();
    for (const Goal& goal : episode.goals)
      goals.push_back({{"position", vec3ToJson(goal.position)},
                       {"radius", static_cast<double>(goal.radius)}});
    value["goals"] = std::move(goals);
  }
  const Instruction& in = episode.instruction;
  nlohmann::json instruction = {{"instruction_text", in.instruction_text}};
  if (!in.instruction_tokens.empty())
    instruction["instruction_tokens"] = in.instruction_tokens;
  // the RxR fields, when present
  if (in.instruction_id)
    instruction["instruction_id"] = std::to_string(*in.instruction_id);
  if (!in.language.empty()) instruction["language"] = in.language;
  if (in.annotator_id) instruction["annotator_id"] = *in.annotator_id;
  if (in.edit_distance) instruction["edit_distance"] = *in.edit_distance;
  if (!in.timed_instruction.empty()) {
    nlohmann::json words = nlohmann::json::array();
    for (const TimedWord& w : in.timed_instruction) {
      nlohmann::json word = {{"word", w.word}};
      if (w.start_time) word["start_time"] = *w.start_time;
      if (w.end_time) word["end_time"] = *w.end_time;
      words.push_back(std::move(word));
    }
    instruction["timed_instruction"] = std::move(words);
  }
  value["instruction"] = std::move(instruction);
  if (!episode.reference_path.empty()) {
    nlohmann::json path = nlohmann::json::array();
    for (const Vec3f& point : episode.reference_path)
      path.push_back(vec3ToJson(point));
    value["reference_path"] = std::move(path);
  }
  return value;
}

nlohmann::json episodesToJson(const EpisodeDataset& dataset) {
  nlohmann::json episodes = nlohmann::json::array();
  for (const Episode& episode : dataset.episodes)
    episodes.push_back(episodeToJson(episode));
  nlohmann::json root = {{"episodes", std::move(episodes)}};
  if (dataset.instruction_vocab)
    root["instruction_vocab"] = dataset.instruction_vocab->toJson();
  return root;
}

void writeEpisodes(const std::filesystem::path& file,
                   const EpisodeDataset& dataset) {
  // validate before touching the disk so a bad dataset leaves no file
  std::string where = strCat("writeEpisodes(): '", file.string(), "'");
  const Vocabulary* vocab =
      dataset.instruction_vocab ? &*dataset.instruction_vocab : nullptr;
  std::unordered_set<int> seen;
  for (size_t i = 0; i < dataset.episodes.size(); ++i) {
    const Episode& episode = dataset.episodes[i];
    std::string context = strCat(where, ": episode ", episode.episode_id);
    validateEpisode(episode, vocab, context);
    VLN_CHECK_ARG(seen.insert(episode.episode_id).second, context,
                  ": field 'episode_id' is duplicated (episode index ", i, ")");
  }
  common::writeJsonFile(file, episodesToJson(dataset));
}

// =========================================================================
// paths
// =========================================================================

std::string sceneScanId(std::string_view sceneId) {
  return std::filesystem::path(sceneId).stem().string();
}

std::filesystem::path resolveScenePath(const std::filesystem::path& scenesDir,
                                       std::string_view sceneId) {
  VLN_CHECK_ARG(!sceneId.empty(), "resolveScenePath(): empty scene id");
  std::filesystem::path id(sceneId);
  std::filesystem::path resolved = id.is_absolute() ? id : scenesDir / id;
  std::error_code ec;
  VLN_CHECK_IO(std::filesystem::is_regular_file(resolved, ec),
               "resolveScenePath(): scene '", sceneId, "' not found: '",
               resolved.string(), "' does not exist (scenes directory '",
               scenesDir.string(), "')");
  return resolved;
}

std::filesystem::path splitEpisodesPath(const std::filesystem::path& root,
                                        std::string_view split) {
  return root / split / (std::string(split) + ".json.gz");
}

std::filesystem::path splitGroundTruthPath(const std::filesystem::path& root,
                                           std::string_view split) {
  return root / split / (std::string(split) + "_gt.json.gz");
}

void keepEvenlySpaced(std::vector<Episode>& episodes, int count) {
  const size_t n = episodes.size();
  if (count < 0 || static_cast<size_t>(count) >= n) return;
  std::vector<Episode> kept;
  kept.reserve(static_cast<size_t>(count));
  for (size_t i = 0; i < static_cast<size_t>(count); ++i)
    kept.push_back(std::move(episodes[i * n / static_cast<size_t>(count)]));
  episodes = std::move(kept);
}

}  // namespace vln::data
