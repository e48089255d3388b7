#include "data/Npz.h"

#include <zlib.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <set>

#include "common/Check.h"
#include "common/FileIo.h"
#include "common/ZipIntegrity.h"

namespace vln::data {
namespace {

// "\x93NUMPY" (NEP 1, numpy/lib/format.py)
constexpr std::string_view kNpyMagic("\x93NUMPY", 6);

// =========================================================================
// the header: a Python dict literal with exactly the keys descr,
// fortran_order and shape
// =========================================================================

struct NpyHeader {
  std::string descr;
  bool fortran_order = false;
  std::vector<int64_t> shape;
};

class HeaderParser {
 public:
  HeaderParser(std::string_view text, std::string_view context)
      : text_(text), context_(context) {}

  NpyHeader parse() {
    NpyHeader header;
    bool haveDescr = false, haveOrder = false, haveShape = false;
    expect('{');
    while (true) {
      skipSpace();
      if (peek() == '}') break;
      const std::string key = string();
      expect(':');
      if (key == "descr" && !haveDescr) {
        header.descr = string();
        haveDescr = true;
      } else if (key == "fortran_order" && !haveOrder) {
        header.fortran_order = boolean();
        haveOrder = true;
      } else if (key == "shape" && !haveShape) {
        header.shape = tuple();
        haveShape = true;
      } else {
        fail(strCat("unexpected or repeated key '", key, "'"));
      }
      skipSpace();
      if (peek() != ',') break;
      ++pos_;
    }
    expect('}');
    skipSpace();
    if (pos_ != text_.size()) fail("text after the closing '}'");
    if (!haveDescr || !haveOrder || !haveShape)
      fail("the keys 'descr', 'fortran_order' and 'shape' are required");
    return header;
  }

 private:
  [[noreturn]] void fail(std::string_view what) const {
    throw std::invalid_argument(strCat(context_, ": malformed .npy header (",
                                       what, " at character ", pos_,
                                       "): ", text_.substr(0, 120)));
  }
  void skipSpace() {
    while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\t' ||
                                   text_[pos_] == '\n' || text_[pos_] == '\r'))
      ++pos_;
  }
  char peek() const { return pos_ < text_.size() ? text_[pos_] : '\0'; }
  void expect(char c) {
    skipSpace();
    if (peek() != c) fail(strCat("expected '", c, "'"));
    ++pos_;
  }
  std::string string() {
    skipSpace();
    const char quote = peek();
    if (quote != '\'' && quote != '"') fail("expected a quoted string");
    const size_t end = text_.find(quote, pos_ + 1);
    if (end == std::string_view::npos) fail("unterminated string");
    std::string value(text_.substr(pos_ + 1, end - pos_ - 1));
    pos_ = end + 1;
    return value;
  }
  bool boolean() {
    skipSpace();
    for (auto [word, value] :
         {std::pair<std::string_view, bool>{"True", true}, {"False", false}}) {
      if (text_.substr(pos_, word.size()) == word) {
        pos_ += word.size();
        return value;
      }
    }
    fail("expected True or False");
  }
  std::vector<int64_t> tuple() {
    expect('(');
    std::vector<int64_t> values;
    while (true) {
      skipSpace();
      if (peek() == ')') break;
      int64_t value = 0;
      bool any = false;
      while (peek() >= '0' && peek() <= '9') {
        const int64_t digit = peek() - '0';
        if (value > (std::numeric_limits<int64_t>::max() - digit) / 10)
          fail("a dimension overflows int64");
        value = value * 10 + digit;
        any = true;
        ++pos_;
      }
      if (!any) fail("expected a non-negative integer dimension");
      // numpy writes Python ints; "3L" comes from Python 2
      if (peek() == 'L') ++pos_;
      values.push_back(value);
      skipSpace();
      if (peek() != ',') break;
      ++pos_;
    }
    expect(')');
    return values;
  }

  std::string_view text_;
  std::string_view context_;
  size_t pos_ = 0;
};

uint64_t littleEndian(std::string_view bytes, size_t offset, int width) {
  uint64_t value = 0;
  for (int i = width - 1; i >= 0; --i)
    value = (value << 8) | static_cast<uint8_t>(bytes[offset + i]);
  return value;
}

// IEEE 754 binary16 -> binary32
float halfToFloat(uint16_t h) {
  const uint32_t sign = static_cast<uint32_t>(h & 0x8000u) << 16;
  const int exponent = (h >> 10) & 0x1f;
  const uint32_t mantissa = h & 0x3ffu;
  uint32_t bits = 0;
  if (exponent == 0x1f) {
    bits = sign | 0x7f800000u | (mantissa << 13);  // inf / nan
  } else if (exponent == 0) {
    // zero or subnormal: mantissa * 2^-24
    const float value = std::ldexp(static_cast<float>(mantissa), -24);
    return sign ? -value : value;
  } else {
    bits = sign | (static_cast<uint32_t>(exponent - 15 + 127) << 23) |
           (mantissa << 13);
  }
  float f = 0.0f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

// =========================================================================
// writing a stored zip (APPNOTE 4.3): local headers, central directory, end
// =========================================================================

void put(std::string& out, uint64_t value, int width) {
  for (int i = 0; i < width; ++i)
    out += static_cast<char>((value >> (8 * i)) & 0xffu);
}

std::string storedZip(
    const std::vector<std::pair<std::string, std::string>>& entries,
    std::string_view where) {
  constexpr uint32_t kDosDate = (0u << 9) | (1u << 5) | 1u;  // 1980-01-01
  std::string out, directory;
  for (const auto& [name, data] : entries) {
    VLN_CHECK_ARG(data.size() < 0xFFFFFFFFu && out.size() < 0xFFFFFFFFu, where,
                  ": entry '", name, "' would need zip64, not written");
    const auto crc = static_cast<uint32_t>(
        crc32_z(0L, reinterpret_cast<const Bytef*>(data.data()), data.size()));
    const uint64_t offset = out.size();
    // local header
    put(out, 0x04034b50u, 4);
    put(out, 20, 2);  // version needed: 2.0
    put(out, 0, 2);   // flags
    put(out, 0, 2);   // method: stored
    put(out, 0, 2);   // time
    put(out, kDosDate, 2);
    put(out, crc, 4);
    put(out, data.size(), 4);
    put(out, data.size(), 4);
    put(out, name.size(), 2);
    put(out, 0, 2);  // extra length
    out += name;
    out += data;
    // its central-directory record
    put(directory, 0x02014b50u, 4);
    put(directory, 20, 2);  // made by
    put(directory, 20, 2);  // needed
    put(directory, 0, 2);
    put(directory, 0, 2);
    put(directory, 0, 2);
    put(directory, kDosDate, 2);
    put(directory, crc, 4);
    put(directory, data.size(), 4);
    put(directory, data.size(), 4);
    put(directory, name.size(), 2);
    put(directory, 0, 2);  // extra
    put(directory, 0, 2);  // comment
    put(directory, 0, 2);  // disk
    put(directory, 0, 2);  // internal attributes
    put(directory, 0, 4);  // external attributes
    put(directory, offset, 4);
    directory += name;
  }
  const uint64_t directoryOffset = out.size();
  out += directory;
  put(out, 0x06054b50u, 4);
  put(out, 0, 2);
  put(out, 0, 2);
  put(out, entries.size(), 2);
  put(out, entries.size(), 2);
  put(out, directory.size(), 4);
  put(out, directoryOffset, 4);
  put(out, 0, 2);
  return out;
}

}  // namespace

// =========================================================================
// reading
// =========================================================================

NpyArray parseNpy(std::string_view bytes, std::string_view context) {
  // magic, version, header length
  VLN_CHECK_ARG(bytes.size() >= 10 && bytes.substr(0, 6) == kNpyMagic, context,
                ": not a .npy array (no \\x93NUMPY magic in its ", bytes.size(),
                " bytes)");
  const int major = static_cast<uint8_t>(bytes[6]);
  VLN_CHECK_ARG(major >= 1 && major <= 3, context, ": .npy version ", major,
                ".", static_cast<int>(static_cast<uint8_t>(bytes[7])),
                " is not 1.0, 2.0 or 3.0");
  const int lengthWidth = major == 1 ? 2 : 4;
  VLN_CHECK_ARG(bytes.size() >= static_cast<size_t>(8 + lengthWidth), context,
                ": .npy file truncated inside its header length");
  const uint64_t headerLength = littleEndian(bytes, 8, lengthWidth);
  const uint64_t dataOffset = 8 + static_cast<uint64_t>(lengthWidth);
  VLN_CHECK_ARG(headerLength <= bytes.size() - dataOffset, context,
                ": .npy header of ", headerLength, " bytes runs past the ",
                bytes.size(), " bytes of the array");
  const NpyHeader header =
      HeaderParser(bytes.substr(dataOffset, headerLength), context).parse();

  // the dtype: little-endian floats only
  VLN_CHECK_ARG(!header.fortran_order, context,
                ": fortran_order arrays are not read (save it C-ordered: "
                "np.ascontiguousarray)");
  VLN_CHECK_ARG(header.descr.size() == 3 && header.descr[0] != '>', context,
                ": big-endian or unsupported dtype '", header.descr,
                "' (read: '<f2', '<f4', '<f8')");
  VLN_CHECK_ARG(
      header.descr == "<f4" || header.descr == "<f2" || header.descr == "<f8",
      context, ": unsupported dtype '", header.descr,
      "' (read: '<f2', '<f4', '<f8')");
  const size_t itemSize = static_cast<size_t>(header.descr[2] - '0');

  // the data must be exactly product(shape) items
  const std::string_view data = bytes.substr(dataOffset + headerLength);
  uint64_t count = 1;
  for (int64_t dim : header.shape) {
    VLN_CHECK_ARG(dim == 0 || count <= data.size() / itemSize /
                                           static_cast<uint64_t>(dim),
                  context, ": shape needs more than the ", data.size(),
                  " data bytes present (truncated?)");
    count *= static_cast<uint64_t>(dim);
  }
  VLN_CHECK_ARG(count * itemSize == data.size(), context, ": shape needs ",
                count * itemSize, " data bytes (", count, " x '", header.descr,
                "'), the file holds ", data.size(),
                count * itemSize > data.size() ? " (truncated)" : "");

  NpyArray array;
  array.shape = header.shape;
  array.values.resize(count);
  for (uint64_t i = 0; i < count; ++i) {
    const char* item = data.data() + i * itemSize;
    if (itemSize == 4) {
      uint32_t bits = static_cast<uint32_t>(littleEndian(data, i * 4, 4));
      std::memcpy(&array.values[i], &bits, 4);
    } else if (itemSize == 8) {
      uint64_t bits = littleEndian(data, i * 8, 8);
      double value = 0.0;
      std::memcpy(&value, &bits, 8);
      array.values[i] = static_cast<float>(value);
    } else {
      array.values[i] = halfToFloat(
          static_cast<uint16_t>(static_cast<uint8_t>(item[0]) |
                                (static_cast<uint8_t>(item[1]) << 8)));
    }
  }
  return array;
}

namespace {

// the arrays of a .npz; only the one named `only` when given (then other
// entries are not parsed and may be anything)
NpzArrays parseArrays(std::string_view bytes, std::string_view source,
                      const NpzLimits& limits, const std::string* only) {
  const std::vector<common::ZipEntry> entries =
      common::readZipEntries(bytes, source,
                             {.max_entries = limits.max_arrays,
                              .max_total_bytes = limits.max_total_bytes});
  NpzArrays arrays;
  std::set<std::string> names;
  for (const common::ZipEntry& entry : entries) {
    const std::string& name = entry.name;
    VLN_CHECK_ARG(!names.contains(name), "'", source, "': entry '", name,
                  "': the archive holds it twice");
    names.insert(name);
    if (only != nullptr && name != *only + ".npy") continue;
    VLN_CHECK_ARG(name.size() > 4 && name.ends_with(".npy"), "'", source,
                  "': entry '", name, "' is not a .npy array");
    const std::string array = name.substr(0, name.size() - 4);
    const std::string context = strCat("'", source, "': array '", array, "'");
    arrays.emplace(array, parseNpy(entry.data, context));
  }
  if (only != nullptr)
    VLN_CHECK_ARG(!arrays.empty(), "'", source, "': has no array '", *only,
                  "' (entries: ", entries.size(), ")");
  return arrays;
}

// runs `read`, prefixing its errors with "readNpz(): "
template <class Read>
auto prefixed(Read&& read) {
  try {
    return read();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(strCat("readNpz(): ", e.what()));
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(strCat("readNpz(): ", e.what()));
  }
}

}  // namespace

NpzArrays parseNpz(std::string_view bytes, std::string_view source,
                   const NpzLimits& limits) {
  return parseArrays(bytes, source, limits, nullptr);
}

NpzArrays readNpz(const std::filesystem::path& file, const NpzLimits& limits) {
  // common::readFile would gunzip a gzip stream; a .npz is never one
  const std::string bytes = common::readFile(file);
  return prefixed([&] { return parseNpz(bytes, file.string(), limits); });
}

NpyArray readNpzArray(const std::filesystem::path& file, std::string_view name,
                      const NpzLimits& limits) {
  const std::string bytes = common::readFile(file);
  const std::string wanted(name);
  return prefixed([&] {
    return std::move(
        parseArrays(bytes, file.string(), limits, &wanted).begin()->second);
  });
}

// =========================================================================
// writing
// =========================================================================

std::string npyBytes(const NpyArray& array) {
  uint64_t count = 1;
  for (int64_t dim : array.shape) {
    VLN_CHECK_ARG(dim >= 0, "npyBytes(): negative dimension ", dim);
    count *= static_cast<uint64_t>(dim);
  }
  VLN_CHECK_ARG(count == array.values.size(), "npyBytes(): shape holds ", count,
                " values, the array ", array.values.size());
  std::string shape = "(";
  for (int64_t dim : array.shape) shape += strCat(dim, ", ");
  if (array.shape.size() > 1) shape.resize(shape.size() - 2);
  if (array.shape.size() == 1) shape.resize(shape.size() - 1);
  shape += ")";
  std::string header = strCat("{'descr': '<f4', 'fortran_order': False, ",
                              "'shape': ", shape, ", }");
  // padded with spaces so that the data starts at a multiple of 64
  const size_t unpadded = 10 + header.size() + 1;
  header.append((64 - unpadded % 64) % 64, ' ');
  header += '\n';
  std::string out(kNpyMagic);
  out += '\x01';
  out += '\x00';
  put(out, header.size(), 2);
  out += header;
  for (float value : array.values) {
    uint32_t bits = 0;
    std::memcpy(&bits, &value, 4);
    put(out, bits, 4);
  }
  return out;
}

void writeNpz(const std::filesystem::path& file, const NpzArrays& arrays) {
  const std::string where = strCat("writeNpz(): '", file.string(), "'");
  std::vector<std::pair<std::string, std::string>> entries;
  for (const auto& [name, array] : arrays) {
    VLN_CHECK_ARG(!name.empty(), where, ": an array has an empty name");
    entries.emplace_back(name + ".npy", npyBytes(array));
  }
  common::writeFileAtomic(file, storedZip(entries, where));
}

std::string storedZipBytes(
    const std::vector<std::pair<std::string, std::string>>& entries) {
  return storedZip(entries, "storedZipBytes()");
}

}  // namespace vln::data
