#pragma once
// JSON files (.json or .json.gz) with errors that name the file and, for
// field access, the path of the field inside it.

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>
#include <string_view>

namespace vln::common {

/// Parses `file` (.json or gzip-compressed .json.gz). Throws
/// std::runtime_error for missing/truncated files and std::invalid_argument
/// naming the file and byte offset for malformed JSON.
nlohmann::json readJsonFile(const std::filesystem::path& file);

/// Parses JSON text; `source` names it in errors.
nlohmann::json parseJson(std::string_view text, std::string_view source);

/// Atomically writes `value` to `file` (gzip when it ends in .gz). `indent` < 0
/// writes compact JSON.
void writeJsonFile(const std::filesystem::path& file,
                   const nlohmann::json& value, int indent = -1);

/// Reads a required member of a JSON object with a contextual error:
/// "<context>: field '<key>' is missing" / "... has the wrong type: <detail>".
template <class T>
T requireField(const nlohmann::json& object, std::string_view key,
               std::string_view context) {
  if (!object.is_object())
    throw std::invalid_argument(std::string(context) +
                                ": expected a JSON object, got " +
                                object.type_name());
  auto it = object.find(std::string(key));
  if (it == object.end())
    throw std::invalid_argument(std::string(context) + ": field '" +
                                std::string(key) + "' is missing");
  try {
    return it->get<T>();
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(std::string(context) + ": field '" +
                                std::string(key) + "' has the wrong type (" +
                                it->type_name() + "): " + e.what());
  }
}

}  // namespace vln::common
