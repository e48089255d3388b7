#include "data/RxrPredictions.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <map>
#include <unordered_map>

#include "common/Check.h"
#include "common/FileIo.h"
#include "common/Json.h"
#include "data/Episode.h"

namespace vln::data {
namespace {

void validate(const RxrPrediction& p, std::string_view context) {
  VLN_CHECK_ARG(p.instruction_id >= 0, context, ": instruction_id ",
                p.instruction_id, " is negative");
  VLN_CHECK_ARG(!p.path.empty(), context, ": instruction ", p.instruction_id,
                " has an empty path");
  for (size_t i = 0; i < p.path.size(); ++i)
    VLN_CHECK_ARG(p.path[i].allFinite(), context, ": instruction ",
                  p.instruction_id, ": path entry ", i, " is not finite");
}

// one line's object; `context` names the source and the line
RxrPrediction predictionFromJson(const nlohmann::json& value,
                                 const std::string& context) {
  VLN_CHECK_ARG(value.is_object(), context, ": expected a JSON object, got ",
                value.type_name());
  for (const auto& [key, unused] : value.items())
    VLN_CHECK_ARG(key == "instruction_id" || key == "path", context,
                  ": unexpected key '", key,
                  "' (a line holds instruction_id and path)");
  RxrPrediction p;
  auto id = value.find("instruction_id");
  VLN_CHECK_ARG(id != value.end(), context,
                ": field 'instruction_id' is missing");
  VLN_CHECK_ARG(id->is_number_integer(), context,
                ": field 'instruction_id' must be an integer, got ",
                id->type_name(), " ", id->dump().substr(0, 40));
  p.instruction_id = id->get<int64_t>();
  auto path = value.find("path");
  VLN_CHECK_ARG(path != value.end(), context, ": field 'path' is missing");
  VLN_CHECK_ARG(path->is_array(), context,
                ": field 'path' must be a list, got ", path->type_name());
  p.path.reserve(path->size());
  for (size_t i = 0; i < path->size(); ++i)
    p.path.push_back(
        vec3FromJson((*path)[i], strCat(context, ": field 'path' entry ", i)));
  validate(p, context);
  return p;
}

// the predictions of one text with the line of each
std::vector<std::pair<RxrPrediction, size_t>> parseLines(
    std::string_view text, std::string_view source) {
  std::vector<std::pair<RxrPrediction, size_t>> out;
  std::unordered_map<int64_t, size_t> lineOf;
  size_t begin = 0;
  for (size_t line = 1; begin < text.size(); ++line) {
    size_t end = text.find('\n', begin);
    if (end == std::string_view::npos) end = text.size();
    std::string_view body = text.substr(begin, end - begin);
    if (!body.empty() && body.back() == '\r') body.remove_suffix(1);
    const std::string context = strCat("'", source, "': line ", line);
    VLN_CHECK_ARG(!body.empty(), context, ": blank line");
    RxrPrediction p =
        predictionFromJson(common::parseJson(body, context), context);
    auto [it, fresh] = lineOf.emplace(p.instruction_id, line);
    VLN_CHECK_ARG(fresh, context, ": instruction_id ", p.instruction_id,
                  " already appears on line ", it->second);
    out.emplace_back(std::move(p), line);
    begin = end + 1;
  }
  return out;
}

}  // namespace

std::vector<Vec3f> rxrPathFromPositions(const std::vector<Vec3f>& positions) {
  std::vector<Vec3f> path;
  for (const Vec3f& p : positions)
    if (path.empty() || path.back() != p) path.push_back(p);
  return path;
}

std::string rxrPredictionsToJsonl(std::vector<RxrPrediction> predictions) {
  std::sort(predictions.begin(), predictions.end(),
            [](const RxrPrediction& a, const RxrPrediction& b) {
              return a.instruction_id < b.instruction_id;
            });
  std::string out;
  for (size_t i = 0; i < predictions.size(); ++i) {
    const RxrPrediction& p = predictions[i];
    validate(p, "rxrPredictionsToJsonl()");
    VLN_CHECK_ARG(
        i == 0 || predictions[i - 1].instruction_id != p.instruction_id,
        "rxrPredictionsToJsonl(): instruction_id ", p.instruction_id,
        " appears twice");
    nlohmann::json path = nlohmann::json::array();
    for (const Vec3f& position : p.path) path.push_back(vec3ToJson(position));
    // key order as VLN-CE writes them
    nlohmann::ordered_json line;
    line["instruction_id"] = p.instruction_id;
    line["path"] = std::move(path);
    out += line.dump();
    out += '\n';
  }
  return out;
}

void writeRxrPredictions(const std::filesystem::path& file,
                         std::vector<RxrPrediction> predictions) {
  // validated and formatted before touching the disk
  common::writeFileAtomic(file, rxrPredictionsToJsonl(std::move(predictions)));
}

std::vector<RxrPrediction> parseRxrPredictions(std::string_view text,
                                               std::string_view source) {
  std::vector<RxrPrediction> out;
  for (auto& [p, line] : parseLines(text, source)) out.push_back(std::move(p));
  return out;
}

std::vector<RxrPrediction> readRxrPredictions(
    const std::filesystem::path& file) {
  return parseRxrPredictions(common::readFile(file), file.string());
}

std::vector<RxrPrediction> mergeRxrPredictions(
    const std::vector<std::filesystem::path>& files) {
  VLN_CHECK_ARG(!files.empty(), "mergeRxrPredictions(): no input files");
  // where each id came from, to name both places of a duplicate
  std::map<int64_t, std::pair<RxrPrediction, std::string>> merged;
  for (const std::filesystem::path& file : files) {
    for (auto& [p, line] : parseLines(common::readFile(file), file.string())) {
      std::string origin = strCat("'", file.string(), "': line ", line);
      const int64_t id = p.instruction_id;
      auto [it, fresh] = merged.try_emplace(id, std::move(p), origin);
      VLN_CHECK_ARG(fresh, "mergeRxrPredictions(): ", origin,
                    ": instruction_id ", id, " already appears in ",
                    it->second.second);
    }
  }
  std::vector<RxrPrediction> out;
  out.reserve(merged.size());
  for (auto& [id, entry] : merged) out.push_back(std::move(entry.first));
  return out;
}

size_t mergeRxrPredictionFiles(
    const std::filesystem::path& out,
    const std::vector<std::filesystem::path>& files) {
  std::vector<RxrPrediction> merged = mergeRxrPredictions(files);
  const size_t count = merged.size();
  writeRxrPredictions(out, std::move(merged));
  return count;
}

}  // namespace vln::data
