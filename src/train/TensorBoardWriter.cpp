#include "train/TensorBoardWriter.h"

#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <optional>
#include <string_view>

#include "common/Check.h"
#include "train/Crc32c.h"

namespace vln::train {
namespace {

// protobuf wire types
constexpr uint32_t kVarint = 0;
constexpr uint32_t kFixed64 = 1;
constexpr uint32_t kLengthDelimited = 2;
constexpr uint32_t kFixed32 = 5;

void putVarint(std::string& out, uint64_t v) {
  while (v >= 0x80) {
    out.push_back(static_cast<char>((v & 0x7F) | 0x80));
    v >>= 7;
  }
  out.push_back(static_cast<char>(v));
}

void putTag(std::string& out, uint32_t field, uint32_t wireType) {
  putVarint(out, (static_cast<uint64_t>(field) << 3) | wireType);
}

template <class T>
void putFixed(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value,
              sizeof(T));  // little-endian hosts only (checked in FeatureStore)
  out.append(bytes, sizeof(T));
}

void putBytes(std::string& out, uint32_t field, const std::string& bytes) {
  putTag(out, field, kLengthDelimited);
  putVarint(out, bytes.size());
  out += bytes;
}

double nowSeconds() {
  return std::chrono::duration<double>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string hostName() {
  char name[256] = {};
  if (::gethostname(name, sizeof(name) - 1) != 0) return "localhost";
  return name;
}

std::string eventHeader(double wallTime, int64_t step) {
  std::string event;
  putTag(event, 1, kFixed64);
  putFixed<double>(event, wallTime);
  putTag(event, 2, kVarint);
  putVarint(event, static_cast<uint64_t>(step));
  return event;
}

// a minimal protobuf reader over one message
struct Reader {
  std::string_view data;
  size_t at = 0;
  bool done() const { return at >= data.size(); }
  uint64_t varint() {
    uint64_t v = 0;
    for (int shift = 0; shift < 64; shift += 7) {
      VLN_CHECK_IO(at < data.size(), "truncated varint");
      const auto byte = static_cast<uint8_t>(data[at++]);
      v |= static_cast<uint64_t>(byte & 0x7F) << shift;
      if (!(byte & 0x80)) return v;
    }
    throw std::runtime_error("overlong varint");
  }
  std::string_view bytes(size_t n) {
    VLN_CHECK_IO(at + n <= data.size(), "truncated field");
    std::string_view out = data.substr(at, n);
    at += n;
    return out;
  }
  void skip(uint32_t wireType) {
    if (wireType == kVarint)
      varint();
    else if (wireType == kFixed64)
      bytes(8);
    else if (wireType == kFixed32)
      bytes(4);
    else if (wireType == kLengthDelimited)
      bytes(varint());
    else
      throw std::runtime_error("unsupported wire type " +
                               std::to_string(wireType));
  }
};

// Summary.Image: height, width, colorspace, encoded_image_string
TensorBoardImage readImage(std::string_view bytes) {
  Reader image{bytes};
  TensorBoardImage out;
  while (!image.done()) {
    const uint64_t key = image.varint();
    const auto field = static_cast<uint32_t>(key >> 3);
    const auto wire = static_cast<uint32_t>(key & 7);
    if (field >= 1 && field <= 3 && wire == kVarint) {
      const auto v = static_cast<int>(image.varint());
      (field == 1 ? out.height : field == 2 ? out.width : out.colorspace) = v;
    } else if (field == 4 && wire == kLengthDelimited) {
      out.encoded = std::string(image.bytes(image.varint()));
    } else {
      image.skip(wire);
    }
  }
  return out;
}

}  // namespace

std::string encodeScalarEvent(
    double wallTime, int64_t step,
    const std::vector<std::pair<std::string, double>>& values) {
  std::string summary;
  for (const auto& [tag, value] : values) {
    std::string v;
    putBytes(v, 1, tag);
    putTag(v, 2, kFixed32);
    putFixed<float>(v, static_cast<float>(value));
    putBytes(summary, 1, v);
  }
  std::string event = eventHeader(wallTime, step);
  putBytes(event, 5, summary);
  return event;
}

std::string encodeImageEvent(double wallTime, int64_t step,
                             const std::string& tag, const std::string& encoded,
                             int width, int height, int channels) {
  std::string image;
  putTag(image, 1, kVarint);
  putVarint(image, static_cast<uint64_t>(height));
  putTag(image, 2, kVarint);
  putVarint(image, static_cast<uint64_t>(width));
  putTag(image, 3, kVarint);
  putVarint(image, static_cast<uint64_t>(channels));
  putBytes(image, 4, encoded);
  std::string value;
  putBytes(value, 1, tag);
  putBytes(value, 4, image);
  std::string summary;
  putBytes(summary, 1, value);
  std::string event = eventHeader(wallTime, step);
  putBytes(event, 5, summary);
  return event;
}

TensorBoardWriter::TensorBoardWriter(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  VLN_CHECK_IO(!ec, "TensorBoardWriter: cannot create '", dir.string(),
               "': ", ec.message());
  const double now = nowSeconds();
  file_ = dir / ("events.out.tfevents." +
                 std::to_string(static_cast<int64_t>(now)) + "." + hostName());
  // a resumed run started within the same second must not append to (and
  // interleave with) the earlier file
  for (int k = 1; std::filesystem::exists(file_); ++k)
    file_ = dir / ("events.out.tfevents." +
                   std::to_string(static_cast<int64_t>(now)) + "." +
                   hostName() + "." + std::to_string(k));
  out_ = std::fopen(file_.c_str(), "wb");
  VLN_CHECK_IO(out_ != nullptr, "TensorBoardWriter: cannot create '",
               file_.string(), "': ", std::strerror(errno));
  std::string event = eventHeader(now, 0);
  putBytes(event, 3, "brain.Event:2");
  writeRecord(event);
}

TensorBoardWriter::~TensorBoardWriter() {
  if (out_) std::fclose(out_);
}

void TensorBoardWriter::addScalars(
    int64_t step, const std::vector<std::pair<std::string, double>>& values,
    double wallTime) {
  if (values.empty()) return;
  writeRecord(
      encodeScalarEvent(wallTime >= 0 ? wallTime : nowSeconds(), step, values));
}

void TensorBoardWriter::addImage(const std::string& tag, int64_t step,
                                 const std::string& encoded, int width,
                                 int height, int channels, double wallTime) {
  VLN_CHECK_ARG(width > 0 && height > 0 &&
                    (channels == 1 || channels == 3 || channels == 4) &&
                    !encoded.empty(),
                "TensorBoardWriter::addImage(): '", tag,
                "': expected a non-empty encoded image with positive size and "
                "1, 3 or 4 channels, got ",
                encoded.size(), " bytes, ", width, "x", height, "x", channels);
  writeRecord(encodeImageEvent(wallTime >= 0 ? wallTime : nowSeconds(), step,
                               tag, encoded, width, height, channels));
}

void TensorBoardWriter::writeRecord(const std::string& data) {
  std::string record;
  const uint64_t length = data.size();
  putFixed<uint64_t>(record, length);
  putFixed<uint32_t>(record, maskCrc32c(crc32c(record)));
  record += data;
  putFixed<uint32_t>(record, maskCrc32c(crc32c(data)));
  const bool ok =
      std::fwrite(record.data(), 1, record.size(), out_) == record.size() &&
      std::fflush(out_) == 0;
  VLN_CHECK_IO(ok, "TensorBoardWriter: cannot write '", file_.string(),
               "': ", std::strerror(errno));
}

TensorBoardFile readTensorBoardFile(const std::filesystem::path& file) {
  std::FILE* in = std::fopen(file.c_str(), "rb");
  VLN_CHECK_IO(in != nullptr, "readTensorBoardFile(): cannot open '",
               file.string(), "'");
  std::string bytes;
  char buffer[1 << 16];
  size_t n = 0;
  while ((n = std::fread(buffer, 1, sizeof(buffer), in)) > 0)
    bytes.append(buffer, n);
  std::fclose(in);

  TensorBoardFile result;
  size_t at = 0;
  auto fixed32 = [&](size_t offset) {
    uint32_t v;
    std::memcpy(&v, bytes.data() + offset, 4);
    return v;
  };
  while (at < bytes.size()) {
    const std::string where = "readTensorBoardFile(): '" + file.string() +
                              "' record at byte " + std::to_string(at);
    VLN_CHECK_IO(at + 12 <= bytes.size(), where, ": truncated header");
    uint64_t length;
    std::memcpy(&length, bytes.data() + at, 8);
    VLN_CHECK_IO(fixed32(at + 8) ==
                     maskCrc32c(crc32c(std::string_view(bytes).substr(at, 8))),
                 where, ": length CRC mismatch");
    VLN_CHECK_IO(at + 12 + length + 4 <= bytes.size(), where,
                 ": truncated data");
    const std::string_view data =
        std::string_view(bytes).substr(at + 12, length);
    VLN_CHECK_IO(fixed32(at + 12 + length) == maskCrc32c(crc32c(data)), where,
                 ": data CRC mismatch");
    at += 12 + length + 4;
    try {
      Reader event{data};
      double wallTime = 0.0;
      int64_t step = 0;
      std::vector<std::pair<std::string, float>> values;
      std::vector<TensorBoardImage> images;
      while (!event.done()) {
        const uint64_t key = event.varint();
        const auto field = static_cast<uint32_t>(key >> 3);
        const auto wire = static_cast<uint32_t>(key & 7);
        if (field == 1 && wire == kFixed64) {
          std::memcpy(&wallTime, event.bytes(8).data(), 8);
        } else if (field == 2 && wire == kVarint) {
          step = static_cast<int64_t>(event.varint());
        } else if (field == 3 && wire == kLengthDelimited) {
          result.file_version = std::string(event.bytes(event.varint()));
        } else if (field == 5 && wire == kLengthDelimited) {
          Reader summary{event.bytes(event.varint())};
          while (!summary.done()) {
            const uint64_t skey = summary.varint();
            if ((skey >> 3) != 1 || (skey & 7) != kLengthDelimited) {
              summary.skip(static_cast<uint32_t>(skey & 7));
              continue;
            }
            Reader value{summary.bytes(summary.varint())};
            std::string tag;
            float simple = 0.0f;
            std::optional<TensorBoardImage> image;
            while (!value.done()) {
              const uint64_t vkey = value.varint();
              if (vkey == ((1u << 3) | kLengthDelimited)) {
                tag = std::string(value.bytes(value.varint()));
              } else if (vkey == ((2u << 3) | kFixed32)) {
                std::memcpy(&simple, value.bytes(4).data(), 4);
              } else if (vkey == ((4u << 3) | kLengthDelimited)) {
                image = readImage(value.bytes(value.varint()));
              } else {
                value.skip(static_cast<uint32_t>(vkey & 7));
              }
            }
            if (image) {
              image->tag = tag;
              images.push_back(std::move(*image));
            } else {
              values.emplace_back(tag, simple);
            }
          }
        } else {
          event.skip(wire);
        }
      }
      for (auto& [tag, value] : values)
        result.scalars.push_back({wallTime, step, tag, value});
      for (TensorBoardImage& image : images) {
        image.wall_time = wallTime;
        image.step = step;
        result.images.push_back(std::move(image));
      }
    } catch (const std::runtime_error& error) {
      throw std::runtime_error(where + ": malformed Event: " + error.what());
    }
  }
  return result;
}

}  // namespace vln::train
