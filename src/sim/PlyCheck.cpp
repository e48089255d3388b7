#include "sim/PlyCheck.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <optional>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "common/Check.h"
#include "common/FileIo.h"

namespace vln::sim {
namespace fs = std::filesystem;

namespace {

enum class PlyFormat { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

struct PlyScalar {
  int bytes = 0;
  bool isSigned = false;
  bool isFloat = false;
};

struct PlyProperty {
  std::string name;
  bool isList = false;
  PlyScalar countType;  // lists only
  PlyScalar valueType;
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

struct PlyLayout {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  size_t bodyOffset = 0;  // first byte after the end_header line
};

// PLY's scalar type names (Paul Bourke's specification and the sized
// aliases assimp and most writers use)
std::optional<PlyScalar> plyScalar(std::string_view word) {
  struct Named {
    std::string_view name;
    PlyScalar type;
  };
  static constexpr Named kTypes[] = {
      {"char", {1, true, false}},     {"uchar", {1, false, false}},
      {"short", {2, true, false}},    {"ushort", {2, false, false}},
      {"int", {4, true, false}},      {"uint", {4, false, false}},
      {"float", {4, true, true}},     {"double", {8, true, true}},
      {"int8", {1, true, false}},     {"uint8", {1, false, false}},
      {"int16", {2, true, false}},    {"uint16", {2, false, false}},
      {"int32", {4, true, false}},    {"uint32", {4, false, false}},
      {"float32", {4, true, true}},   {"float64", {8, true, true}}};
  for (const Named& t : kTypes)
    if (t.name == word) return t.type;
  return std::nullopt;
}

// an element count: decimal digits only
std::optional<uint64_t> plyCount(std::string_view word) {
  if (word.empty() || word.size() > 18 ||
      !std::all_of(word.begin(), word.end(),
                   [](char c) { return c >= '0' && c <= '9'; }))
    return std::nullopt;
  return std::stoull(std::string(word));
}

// Bytes of the file for a message: at most `limit` of them, any but
// printable ASCII as \xNN (a NUL would end the message).
std::string printable(std::string_view text, size_t limit = 40) {
  std::string out;
  for (unsigned char c : text.substr(0, limit)) {
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      static constexpr char kHex[] = "0123456789abcdef";
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  return out;
}

// The header, line by line. Debian's assimp 5.2 loops forever without an
// end_header line, and corrupts its heap on a vertex element lacking x, y
// or z, on a property of an unknown type and on an element declared twice:
// every line must be one of the header's own forms, every element and
// property name unique in its scope. Returns nothing for a file that is not PLY.
std::optional<PlyLayout> readPlyHeader(const fs::path& file,
                                       std::string_view bytes,
                                       bool plyExtension) {
  PlyLayout layout;
  bool first = true;
  size_t pos = 0;
  constexpr size_t kMaxHeaderBytes = 1 << 20;
  bool formatSeen = false;
  while (pos < bytes.size() && pos < kMaxHeaderBytes) {
    const size_t end = std::min(bytes.find('\n', pos), bytes.size());
    std::string line(bytes.substr(pos, end - pos));
    pos = end + 1;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    // words are separated by blanks and tabs only: assimp does not take
    // every isspace() character for a separator, and "end_header\v..."
    // passed this check while assimp looped forever looking for the end
    // (found by fuzzing)
    std::vector<std::string> words;
    for (size_t i = 0; i < line.size();) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      size_t j = i;
      while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
      if (j > i) words.push_back(line.substr(i, j - i));
      i = j;
    }
    if (first && (words.empty() || !words[0].starts_with("ply")) &&
        !plyExtension)
      return std::nullopt;
    const bool firstLine = first;
    first = false;
    if (words.empty()) continue;
    auto bad = [&](std::string_view why) {
      return std::invalid_argument(strCat("loadScene(): ", file,
                                          " is a PLY file with a malformed "
                                          "header line (",
                                          why, "): '", printable(line, 80),
                                          "'"));
    };
    if (words[0] == "end_header") {
      VLN_CHECK_ARG(formatSeen, "loadScene(): ", file,
                    " is a PLY file whose header has no format line");
      for (const PlyElement& element : layout.elements) {
        if (element.name != "vertex") continue;
        auto has = [&](std::string_view name) {
          return std::any_of(element.properties.begin(),
                             element.properties.end(),
                             [&](const PlyProperty& p) { return p.name == name; });
        };
        VLN_CHECK_ARG(has("x") && has("y") && has("z"), "loadScene(): ", file,
                      " is a PLY file whose vertex element lacks x, y or z");
      }
      layout.bodyOffset = std::min(pos, bytes.size());
      return layout;
    }
    if (words[0] == "element") {
      std::optional<uint64_t> count;
      if (words.size() != 3 || !(count = plyCount(words[2])))
        throw bad("expected 'element <name> <count>'");
      // assimp sizes an element's arrays by its first declaration and
      // fills them from every one: a heap overflow (found by fuzzing)
      for (const PlyElement& earlier : layout.elements)
        if (earlier.name == words[1]) throw bad("an element declared twice");
      layout.elements.push_back({words[1], *count, {}});
    } else if (words[0] == "property") {
      if (layout.elements.empty()) throw bad("a property before any element");
      PlyProperty property;
      property.name = words.back();
      std::optional<PlyScalar> countType, valueType;
      if (words.size() == 5 && words[1] == "list" &&
          (countType = plyScalar(words[2])) &&
          (valueType = plyScalar(words[3])) && !countType->isFloat) {
        property.isList = true;
        property.countType = *countType;
        property.valueType = *valueType;
      } else if (words.size() == 3 && (valueType = plyScalar(words[1]))) {
        property.valueType = *valueType;
      } else {
        throw bad(
            "expected 'property <type> <name>' or 'property list <integer "
            "type> <type> <name>' with PLY's types");
      }
      // which of two same-named properties assimp reads is its choice
      for (const PlyProperty& earlier : layout.elements.back().properties)
        if (earlier.name == property.name)
          throw bad("a property declared twice in its element");
      layout.elements.back().properties.push_back(property);
    } else if (words[0] == "format") {
      // assimp reads one format and a body of the other (6.9 GB for a
      // header declaring ascii, then binary; found by fuzzing)
      if (formatSeen) throw bad("a second format line");
      formatSeen = true;
      if (words.size() != 3) throw bad("expected 'format <format> <version>'");
      if (words[1] == "ascii")
        layout.format = PlyFormat::kAscii;
      else if (words[1] == "binary_little_endian")
        layout.format = PlyFormat::kBinaryLittleEndian;
      else if (words[1] == "binary_big_endian")
        layout.format = PlyFormat::kBinaryBigEndian;
      else
        throw bad(
            "expected 'format ascii|binary_little_endian|"
            "binary_big_endian <version>'");
    } else if (words[0] == "ply") {
      if (!firstLine) throw bad("'ply' after the first line");
    } else if (words[0] != "comment" && words[0] != "obj_info") {
      throw bad("not a PLY header keyword");
    }
  }
  // an empty file has no magic: only its extension can make it a PLY file
  if (first && !plyExtension) return std::nullopt;
  throw std::invalid_argument(
      strCat("loadScene(): ", file,
             " is a PLY file whose header has no end_header "
             "line (truncated?)"));
}

// Where a body check failed, for the message.
std::string where(const fs::path& file, const PlyElement& element,
                  uint64_t row, const PlyProperty& property) {
  return strCat("loadScene(): ", file, " PLY element '", element.name,
                "' row ", row, " property '", property.name, "'");
}

// The largest list count a count type can hold.
uint64_t maxCount(const PlyScalar& type) {
  const int bits = type.bytes * 8 - (type.isSigned ? 1 : 0);
  return bits >= 64 ? std::numeric_limits<uint64_t>::max()
                    : (uint64_t{1} << bits) - 1;
}

// ASCII body: one row per line (assimp reads it line by line and ignores
// what a row leaves over), numbers separated by blanks and tabs; anything
// else in a token makes it a non-number.
class AsciiRows {
 public:
  explicit AsciiRows(std::string_view text) : text_(text) {}

  /// The next line, without its '\n' and a '\r' before it; false at the
  /// end of the text.
  bool next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    const size_t end = std::min(text_.find('\n', pos_), text_.size());
    line = text_.substr(pos_, end - pos_);
    pos_ = end + 1;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    return true;
  }

  /// The blank- and tab-separated words of a line.
  static void split(std::string_view line,
                    std::vector<std::string_view>& tokens) {
    tokens.clear();
    for (size_t i = 0; i < line.size();) {
      while (i < line.size() && isBlank(line[i])) ++i;
      size_t j = i;
      while (j < line.size() && !isBlank(line[j])) ++j;
      if (j > i) tokens.push_back(line.substr(i, j - i));
      i = j;
    }
  }

 private:
  static bool isBlank(char c) { return c == ' ' || c == '\t'; }
  std::string_view text_;
  size_t pos_ = 0;
};

// assimp also ends a line at '\r', '\f' and NUL (a NUL in what a row left
// over made it read the rest as a row with a list of 333333333355 entries:
// 20 GB, found by fuzzing), so a row's line holds printable ASCII and tabs
// only.
std::optional<unsigned char> firstForeignByte(std::string_view line) {
  for (unsigned char c : line)
    if (!(c == '\t' || (c >= 0x20 && c < 0x7f))) return c;
  return std::nullopt;
}

bool isNumber(std::string_view token) {
  if (!token.empty() && token[0] == '+') token.remove_prefix(1);
  double value = 0;
  const auto [end, ec] =
      std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && end == token.data() + token.size();
}

void checkAsciiBody(const fs::path& file, const PlyLayout& layout,
                    std::string_view body) {
  AsciiRows rows(body);
  std::vector<std::string_view> tokens;
  for (const PlyElement& element : layout.elements) {
    for (uint64_t row = 0; row < element.count; ++row) {
      std::string_view line;
      VLN_CHECK_ARG(rows.next(line), "loadScene(): ", file, " PLY element '",
                    element.name, "' row ", row,
                    ": the file ends before it (truncated, or the header "
                    "declares more rows than there are)");
      if (auto byte = firstForeignByte(line))
        throw std::invalid_argument(strCat(
            "loadScene(): ", file, " PLY element '", element.name, "' row ",
            row, ": its line holds the byte ",
            printable(std::string(1, static_cast<char>(*byte))),
            " (only printable ASCII and tabs belong in an ASCII body)"));
      AsciiRows::split(line, tokens);
      // assimp reads most blank lines as rows of zeros (and skips some)
      VLN_CHECK_ARG(!tokens.empty(), "loadScene(): ", file,
                    " PLY element '", element.name, "' row ", row,
                    ": a blank line where the row should be");
      size_t t = 0;
      auto take = [&](const PlyProperty& property, std::string_view what) {
        VLN_CHECK_ARG(t < tokens.size(), where(file, element, row, property),
                      ": the row's line ends before its ", what);
        const std::string_view token = tokens[t++];
        VLN_CHECK_ARG(isNumber(token), where(file, element, row, property),
                      ": '", printable(token), "' is not a number");
        return token;
      };
      for (const PlyProperty& property : element.properties) {
        const std::string_view token = take(property, "value");
        if (!property.isList) continue;
        uint64_t count = 0;
        const auto [end, ec] =
            std::from_chars(token.data(), token.data() + token.size(), count);
        VLN_CHECK_ARG(ec == std::errc() &&
                          end == token.data() + token.size() &&
                          count <= maxCount(property.countType),
                      where(file, element, row, property), ": list count '",
                      printable(token),
                      "' is not an integer its count type holds");
        VLN_CHECK_ARG(count <= tokens.size() - t,
                      where(file, element, row, property), ": a list of ",
                      count, " entries, but its line holds ",
                      tokens.size() - t, " more values");
        for (uint64_t k = 0; k < count; ++k) take(property, "list entries");
      }
    }
  }
}

uint64_t readUnsigned(const unsigned char* p, int bytes, bool bigEndian) {
  uint64_t value = 0;
  for (int i = 0; i < bytes; ++i)
    value |= uint64_t{p[bigEndian ? bytes - 1 - i : i]} << (8 * i);
  return value;
}

void checkBinaryBody(const fs::path& file, const PlyLayout& layout,
                     std::string_view body) {
  const bool bigEndian = layout.format == PlyFormat::kBinaryBigEndian;
  const auto* data = reinterpret_cast<const unsigned char*>(body.data());
  size_t pos = 0;
  const size_t size = body.size();
  for (const PlyElement& element : layout.elements) {
    for (uint64_t row = 0; row < element.count; ++row) {
      for (const PlyProperty& property : element.properties) {
        const size_t head = property.isList ? property.countType.bytes
                                            : property.valueType.bytes;
        VLN_CHECK_ARG(size - pos >= head, where(file, element, row, property),
                      ": the file ends before it (truncated, or the header "
                      "declares more rows than there are)");
        if (!property.isList) {
          pos += head;
          continue;
        }
        const int bytes = property.countType.bytes;
        uint64_t count = readUnsigned(data + pos, bytes, bigEndian);
        pos += head;
        const bool negative =
            property.countType.isSigned && (count >> (8 * bytes - 1)) != 0;
        VLN_CHECK_ARG(!negative, where(file, element, row, property),
                      ": negative list count");
        VLN_CHECK_ARG(count <= (size - pos) / property.valueType.bytes,
                      where(file, element, row, property), ": a list of ",
                      count, " entries is longer than the ", size - pos,
                      " bytes left in the file");
        pos += count * property.valueType.bytes;
      }
    }
  }
}

// assimp's PLY detection: the first word of the file starts with "ply"
bool startsWithPlyMagic(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  char head[64] = {};
  in.read(head, sizeof head);
  std::string_view text(head, static_cast<size_t>(in.gcount()));
  text = text.substr(0, text.find('\n'));
  const size_t start = text.find_first_not_of(" \t");
  return start != std::string_view::npos && text.substr(start).starts_with("ply");
}

}  // namespace

void checkPlyFile(const fs::path& file) {
  std::string extension = file.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  const bool plyExtension = extension == ".ply";
  if (!plyExtension && !startsWithPlyMagic(file)) return;
  const std::string bytes = common::readFile(file);
  const std::optional<PlyLayout> layout =
      readPlyHeader(file, bytes, plyExtension);
  if (!layout) return;
  // An element without properties has rows of no bytes: nothing bounds
  // its count, and assimp allocates per row.
  for (const PlyElement& element : layout->elements)
    VLN_CHECK_ARG(element.count == 0 || !element.properties.empty(),
                  "loadScene(): ", file, " PLY element '", element.name,
                  "' declares ", element.count, " rows but no properties");
  const std::string_view body = std::string_view(bytes).substr(layout->bodyOffset);
  if (layout->format == PlyFormat::kAscii)
    checkAsciiBody(file, *layout, body);
  else
    checkBinaryBody(file, *layout, body);
}

}  // namespace vln::sim
