#include "common/ZipIntegrity.h"

#include <zlib.h>

#include <algorithm>
#include <limits>
#include <vector>

#include "common/Check.h"

namespace vln::common {
namespace {

// record signatures and sizes (APPNOTE 4.3)
constexpr uint32_t kLocalHeader = 0x04034b50;
constexpr uint32_t kCentralHeader = 0x02014b50;
constexpr uint32_t kEndOfCentralDirectory = 0x06054b50;
constexpr uint32_t kZip64End = 0x06064b50;
constexpr uint32_t kZip64Locator = 0x07064b50;
constexpr size_t kLocalHeaderSize = 30;
constexpr size_t kCentralHeaderSize = 46;
constexpr size_t kEndSize = 22;
constexpr size_t kZip64EndSize = 56;
constexpr size_t kZip64LocatorSize = 20;
constexpr uint16_t kZip64ExtraId = 0x0001;
constexpr uint32_t kMax32 = 0xFFFFFFFFu;
constexpr uint16_t kMax16 = 0xFFFFu;
// caps one recorded size when summing them, so the sum cannot overflow
constexpr uint64_t kMax64Half = uint64_t{1} << 62;

// little-endian reads at checked offsets
class Reader {
 public:
  Reader(std::string_view bytes, std::string_view source)
      : bytes_(bytes), source_(source) {}

  uint64_t uint(uint64_t offset, int width, std::string_view what) const {
    need(offset, static_cast<uint64_t>(width), what);
    uint64_t value = 0;
    for (int i = width - 1; i >= 0; --i)
      value = (value << 8) | static_cast<uint8_t>(bytes_[offset + i]);
    return value;
  }
  std::string_view view(uint64_t offset, uint64_t size,
                        std::string_view what) const {
    need(offset, size, what);
    return bytes_.substr(offset, size);
  }
  void need(uint64_t offset, uint64_t size, std::string_view what) const {
    VLN_CHECK_IO(offset <= bytes_.size() && size <= bytes_.size() - offset, "'",
                 source_, "' is truncated or not a zip archive: its ", what,
                 " (", size, " bytes at offset ", offset, ") lies beyond its ",
                 bytes_.size(), " bytes");
  }
  [[noreturn]] void fail(std::string_view what) const {
    throw std::runtime_error(
        strCat("'", source_, "' is not an intact zip archive: ", what));
  }
  uint64_t size() const { return bytes_.size(); }

 private:
  std::string_view bytes_;
  std::string_view source_;
};

// where the central directory is and how many entries it holds
struct Directory {
  uint64_t offset = 0;
  uint64_t size = 0;
  uint64_t entries = 0;
};

Directory findDirectory(const Reader& in) {
  // the end record is the last one, followed only by its comment
  if (in.size() < kEndSize)
    in.fail(strCat(in.size(), " bytes are fewer than an end record"));
  uint64_t end = in.size() - kEndSize;
  const uint64_t lowest =
      in.size() > kEndSize + kMax16 ? in.size() - kEndSize - kMax16 : 0;
  for (;; --end) {
    if (in.uint(end, 4, "end record") == kEndOfCentralDirectory &&
        end + kEndSize + in.uint(end + 20, 2, "comment length") == in.size())
      break;
    if (end == lowest) in.fail("no end-of-central-directory record");
  }
  Directory dir;
  dir.entries = in.uint(end + 10, 2, "entry count");
  dir.size = in.uint(end + 12, 4, "directory size");
  dir.offset = in.uint(end + 16, 4, "directory offset");
  // zip64: the locator sits right before the end record
  if (end >= kZip64LocatorSize &&
      in.uint(end - kZip64LocatorSize, 4, "zip64 locator") == kZip64Locator) {
    const uint64_t record =
        in.uint(end - kZip64LocatorSize + 8, 8, "zip64 end offset");
    if (in.uint(record, 4, "zip64 end record") != kZip64End)
      in.fail("the zip64 locator points at no zip64 end record");
    in.need(record, kZip64EndSize, "zip64 end record");
    dir.entries = in.uint(record + 32, 8, "zip64 entry count");
    dir.size = in.uint(record + 40, 8, "zip64 directory size");
    dir.offset = in.uint(record + 48, 8, "zip64 directory offset");
  } else if (dir.entries == kMax16 || dir.size == kMax32 ||
             dir.offset == kMax32) {
    in.fail("the end record needs zip64 values but there is no zip64 locator");
  }
  in.need(dir.offset, dir.size, "central directory");
  return dir;
}

// the CRC-32 and length of an entry's data, inflated when deflated
struct Content {
  uint32_t crc = 0;
  uint64_t size = 0;
};

Content storedContent(std::string_view data, std::string* keep) {
  if (keep != nullptr) keep->assign(data);
  Content c;
  c.crc = static_cast<uint32_t>(
      crc32_z(0L, reinterpret_cast<const Bytef*>(data.data()), data.size()));
  c.size = data.size();
  return c;
}

Content inflatedContent(std::string_view data, uint64_t expected,
                        const Reader& in, const std::string& entry,
                        std::string* keep) {
  z_stream z{};
  VLN_CHECK_IO(inflateInit2(&z, -MAX_WBITS) == Z_OK,
               "verifyZipIntegrity(): zlib cannot start inflating");
  Content c;
  c.crc = static_cast<uint32_t>(crc32_z(0L, Z_NULL, 0));
  std::vector<Bytef> out(1 << 16);
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  size_t left = data.size();
  int rc = Z_OK;
  // stops past the recorded size: a damaged stream may inflate without end
  while (c.size <= expected) {
    if (z.avail_in == 0 && left > 0) {
      const auto chunk = static_cast<uInt>(
          std::min<size_t>(left, std::numeric_limits<uInt>::max()));
      z.avail_in = chunk;
      left -= chunk;
    }
    z.next_out = out.data();
    z.avail_out = static_cast<uInt>(out.size());
    rc = inflate(&z, Z_NO_FLUSH);
    if (rc != Z_OK && rc != Z_STREAM_END) break;
    const size_t produced = out.size() - z.avail_out;
    c.crc = static_cast<uint32_t>(crc32_z(c.crc, out.data(), produced));
    if (keep != nullptr && c.size + produced <= expected)
      keep->append(reinterpret_cast<const char*>(out.data()), produced);
    c.size += produced;
    if (rc == Z_STREAM_END) break;
  }
  const bool whole = rc == Z_STREAM_END && z.avail_in == 0 && left == 0;
  inflateEnd(&z);
  if (!whole)
    in.fail(strCat("entry '", entry, "' holds a broken deflate stream"));
  return c;
}

// the 64-bit values an entry's zip64 extra field holds for its 0xFFFFFFFF
// fields, in the order of APPNOTE 4.5.3
void readZip64Extra(const Reader& in, uint64_t extra, uint64_t extraSize,
                    const std::string& entry, uint64_t* uncompressed,
                    uint64_t* compressed, uint64_t* localOffset) {
  for (uint64_t at = extra; at + 4 <= extra + extraSize;) {
    const auto id = in.uint(at, 2, "extra field id");
    const uint64_t size = in.uint(at + 2, 2, "extra field size");
    if (id == kZip64ExtraId) {
      uint64_t field = at + 4;
      for (uint64_t* value : {uncompressed, compressed, localOffset}) {
        if (*value != kMax32) continue;
        if (field + 8 > at + 4 + size)
          in.fail(strCat("entry '", entry, "' has a short zip64 extra field"));
        *value = in.uint(field, 8, "zip64 extra value");
        field += 8;
      }
      return;
    }
    at += 4 + size;
  }
  if (*uncompressed == kMax32 || *compressed == kMax32 ||
      *localOffset == kMax32)
    in.fail(strCat("entry '", entry, "' needs a zip64 extra field"));
}

// walks the archive, checking every entry; appends the entries to `keep`
// when given, after checking the recorded sizes against `limits`
ZipSummary walkArchive(std::string_view bytes, std::string_view source,
                       std::vector<ZipEntry>* keep,
                       const ZipReadLimits* limits) {
  const Reader in(bytes, source);
  const Directory dir = findDirectory(in);
  if (limits != nullptr &&
      dir.entries > static_cast<uint64_t>(limits->max_entries))
    in.fail(strCat("it records ", dir.entries, " entries, more than the ",
                   limits->max_entries, " allowed"));
  uint64_t recordedTotal = 0;
  ZipSummary summary;
  uint64_t at = dir.offset;
  const uint64_t directoryEnd = dir.offset + dir.size;
  for (uint64_t i = 0; i < dir.entries; ++i) {
    // the central directory's record of entry i
    if (at + kCentralHeaderSize > directoryEnd ||
        in.uint(at, 4, "central header") != kCentralHeader)
      in.fail(strCat("the central directory ends after ", i, " of its ",
                     dir.entries, " entries"));
    const auto flags = in.uint(at + 8, 2, "flags");
    const auto method = in.uint(at + 10, 2, "method");
    const auto crc = static_cast<uint32_t>(in.uint(at + 16, 4, "crc"));
    uint64_t compressed = in.uint(at + 20, 4, "compressed size");
    uint64_t uncompressed = in.uint(at + 24, 4, "uncompressed size");
    const uint64_t nameSize = in.uint(at + 28, 2, "name length");
    const uint64_t extraSize = in.uint(at + 30, 2, "extra length");
    const uint64_t commentSize = in.uint(at + 32, 2, "comment length");
    uint64_t local = in.uint(at + 42, 4, "local header offset");
    const std::string name(in.view(at + kCentralHeaderSize, nameSize, "name"));
    readZip64Extra(in, at + kCentralHeaderSize + nameSize, extraSize, name,
                   &uncompressed, &compressed, &local);
    at += kCentralHeaderSize + nameSize + extraSize + commentSize;
    if (at > directoryEnd)
      in.fail(strCat("entry '", name, "' runs past the central directory"));
    if (flags & 1u) in.fail(strCat("entry '", name, "' is encrypted"));

    // its local header must name the same entry and method
    if (in.uint(local, 4, "local header") != kLocalHeader)
      in.fail(
          strCat("entry '", name, "' has no local header at offset ", local));
    in.need(local, kLocalHeaderSize, "local header");
    const uint64_t localName = in.uint(local + 26, 2, "local name length");
    const uint64_t localExtra = in.uint(local + 28, 2, "local extra length");
    if (in.uint(local + 8, 2, "local method") != method ||
        in.view(local + kLocalHeaderSize, localName, "local name") != name)
      in.fail(
          strCat("entry '", name,
                 "': its local header disagrees with the central directory"));
    const std::string_view data =
        in.view(local + kLocalHeaderSize + localName + localExtra, compressed,
                strCat("entry '", name, "'"));

    // a zip bomb records sizes beyond the limits: refused before inflating
    std::string* kept = nullptr;
    if (keep != nullptr) {
      recordedTotal += std::min<uint64_t>(uncompressed, kMax64Half);
      if (recordedTotal > static_cast<uint64_t>(limits->max_total_bytes))
        in.fail(strCat("entry '", name, "' takes its entries to ",
                       recordedTotal, " uncompressed bytes, more than the ",
                       limits->max_total_bytes, " allowed"));
      keep->push_back({name, {}});
      kept = &keep->back().data;
      kept->reserve(uncompressed);
    }

    // its data: the recorded size and CRC-32
    Content content;
    if (method == 0) {
      if (compressed != uncompressed)
        in.fail(strCat("stored entry '", name, "' records ", compressed,
                       " compressed and ", uncompressed,
                       " uncompressed bytes"));
      content = storedContent(data, kept);
    } else if (method == 8) {
      content = inflatedContent(data, uncompressed, in, name, kept);
    } else {
      in.fail(strCat("entry '", name, "' uses compression method ", method,
                     " (only stored and deflate are read)"));
    }
    if (content.size != uncompressed)
      in.fail(strCat("entry '", name, "' holds ", content.size,
                     " bytes, its header says ", uncompressed));
    if (content.crc != crc)
      in.fail(strCat("entry '", name, "' has CRC-32 ", content.crc,
                     ", its header records ", crc));
    ++summary.entries;
    summary.uncompressed_bytes += static_cast<int64_t>(uncompressed);
  }
  return summary;
}

}  // namespace

ZipSummary verifyZipIntegrity(std::string_view bytes, std::string_view source) {
  return walkArchive(bytes, source, nullptr, nullptr);
}

std::vector<ZipEntry> readZipEntries(std::string_view bytes,
                                     std::string_view source,
                                     const ZipReadLimits& limits) {
  std::vector<ZipEntry> entries;
  walkArchive(bytes, source, &entries, &limits);
  return entries;
}

}  // namespace vln::common
