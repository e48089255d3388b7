#include "common/Json.h"

#include "common/Check.h"
#include "common/FileIo.h"

namespace vln::common {

nlohmann::json parseJson(std::string_view text, std::string_view source) {
  try {
    return nlohmann::json::parse(text.begin(), text.end());
  } catch (const nlohmann::json::parse_error& e) {
    throw std::invalid_argument(std::string(source) +
                                ": malformed JSON at byte " +
                                std::to_string(e.byte) + ": " + e.what());
  }
}

nlohmann::json readJsonFile(const std::filesystem::path& file) {
  return parseJson(readFile(file), file.string());
}

void writeJsonFile(const std::filesystem::path& file,
                   const nlohmann::json& value, int indent) {
  writeFileAtomic(file, value.dump(indent));
}

}  // namespace vln::common
