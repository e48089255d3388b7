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
  } catch (const nlohmann::json::exception& e) {
    // the parser's other errors: out_of_range 406, a number beyond double
    // ("1e999"), found by fuzzing every JSON reader
    throw std::invalid_argument(std::string(source) + ": malformed JSON: " +
                                e.what());
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
