#include "viz/Gif.h"

#include <algorithm>
#include <cstdlib>
#include <vector>

#include "common/Check.h"

namespace vln::viz {
namespace {

// the colour cube's six levels are k * 51; the 39 extra greys sit between
// them at round((i + 1) * 255 / 41), none equal to a cube level; the last
// entry is the transparent one
constexpr int kCubeLevels = 6;
constexpr int kCubeStep = 51;
constexpr int kCubeColors = kCubeLevels * kCubeLevels * kCubeLevels;
constexpr int kExtraGreys = kGifTransparentIndex - kCubeColors;

// LZW over 8-bit indices (GIF89a appendix F): codes 0-255 are the indices
// themselves, 256 clears the table, 257 ends the data
constexpr int kMinCodeSize = 8;
constexpr int kClearCode = 1 << kMinCodeSize;
constexpr int kEndCode = kClearCode + 1;
constexpr int kFirstFreeCode = kClearCode + 2;
constexpr int kMaxCodeSize = 12;
constexpr int kMaxCodes = 1 << kMaxCodeSize;

void putU16(std::string& out, int value) {
  out.push_back(static_cast<char>(value & 0xFF));
  out.push_back(static_cast<char>((value >> 8) & 0xFF));
}

// the palette and, for each sum r + g + b (0..765), the palette index of
// the grey nearest to that mean
struct PaletteTables {
  std::array<std::array<uint8_t, 3>, kGifPaletteSize> colors{};
  std::array<uint8_t, 3 * 255 + 1> greyBySum{};

  PaletteTables() {
    for (int r = 0; r < kCubeLevels; ++r)
      for (int g = 0; g < kCubeLevels; ++g)
        for (int b = 0; b < kCubeLevels; ++b)
          colors[static_cast<size_t>(r * 36 + g * 6 + b)] = {
              static_cast<uint8_t>(r * kCubeStep),
              static_cast<uint8_t>(g * kCubeStep),
              static_cast<uint8_t>(b * kCubeStep)};
    for (int i = 0; i < kExtraGreys; ++i) {
      const auto level = static_cast<uint8_t>(((i + 1) * 255 * 2 + 41) / 82);
      colors[static_cast<size_t>(kCubeColors + i)] = {level, level, level};
    }
    // every grey of the palette (the cube's six and the extra 39); the
    // distance from (r, g, b) to grey v is minimal where |3v - sum| is
    for (int sum = 0; sum <= 3 * 255; ++sum) {
      int best = 0;
      int bestDistance = 1 << 30;
      for (int i = 0; i < kGifTransparentIndex; ++i) {
        const auto& c = colors[static_cast<size_t>(i)];
        if (c[0] != c[1] || c[1] != c[2]) continue;
        const int distance = std::abs(3 * c[0] - sum);
        if (distance < bestDistance) {
          bestDistance = distance;
          best = i;
        }
      }
      greyBySum[static_cast<size_t>(sum)] = static_cast<uint8_t>(best);
    }
  }
};

const PaletteTables& tables() {
  static const PaletteTables t;
  return t;
}

int squaredDistance(const std::array<uint8_t, 3>& c, int r, int g, int b) {
  const int dr = r - c[0], dg = g - c[1], db = b - c[2];
  return dr * dr + dg * dg + db * db;
}

// LSB-first bit packing of variable-width codes (GIF's order)
class BitWriter {
 public:
  explicit BitWriter(std::string& out) : out_(out) {}
  void put(int code, int bits) {
    buffer_ |= static_cast<uint32_t>(code) << count_;
    count_ += bits;
    while (count_ >= 8) {
      out_.push_back(static_cast<char>(buffer_ & 0xFF));
      buffer_ >>= 8;
      count_ -= 8;
    }
  }
  void flush() {
    if (count_ > 0) out_.push_back(static_cast<char>(buffer_ & 0xFF));
    buffer_ = 0;
    count_ = 0;
  }

 private:
  std::string& out_;
  uint32_t buffer_ = 0;
  int count_ = 0;
};

// the string table as (prefix code, next index) -> code, open addressing
// over twice as many slots as the table can hold
class CodeTable {
 public:
  CodeTable() : keys_(kSlots, kEmpty), codes_(kSlots, 0) {}
  void clear() { std::fill(keys_.begin(), keys_.end(), kEmpty); }
  int find(int prefix, int index) const {
    const int32_t key = (prefix << 8) | index;
    for (size_t slot = hash(key);; slot = (slot + 1) & (kSlots - 1)) {
      if (keys_[slot] == kEmpty) return -1;
      if (keys_[slot] == key) return codes_[slot];
    }
  }
  void insert(int prefix, int index, int code) {
    const int32_t key = (prefix << 8) | index;
    size_t slot = hash(key);
    while (keys_[slot] != kEmpty) slot = (slot + 1) & (kSlots - 1);
    keys_[slot] = key;
    codes_[slot] = static_cast<int16_t>(code);
  }

 private:
  static constexpr size_t kSlots = 2 * kMaxCodes;  // 2^13
  static constexpr int32_t kEmpty = -1;
  static size_t hash(int32_t key) {
    // Knuth's multiplicative hash: the top 13 bits of key * 2^32 / phi
    return (static_cast<uint32_t>(key) * 2654435761u) >> (32 - 13);
  }
  std::vector<int32_t> keys_;
  std::vector<int16_t> codes_;
};

// the LZW code stream of `indices` (GIFCOMPR's scheme: the code width
// grows once the next free code no longer fits, checked after each emitted
// code, as a decoder does after adding its entry; a full table is cleared)
std::string lzwCompress(const std::vector<uint8_t>& indices) {
  std::string packed;
  BitWriter bits(packed);
  CodeTable table;
  int codeSize = kMinCodeSize + 1;
  int next = kFirstFreeCode;
  bits.put(kClearCode, codeSize);
  // emits `code` and widens the codes when the decoder will
  auto emit = [&](int code) {
    bits.put(code, codeSize);
    if (next >= (1 << codeSize) && codeSize < kMaxCodeSize) ++codeSize;
  };
  int prefix = indices.front();
  for (size_t i = 1; i < indices.size(); ++i) {
    const int index = indices[i];
    const int code = table.find(prefix, index);
    if (code >= 0) {
      prefix = code;
      continue;
    }
    emit(prefix);
    if (next < kMaxCodes) {
      table.insert(prefix, index, next++);
    } else {
      bits.put(kClearCode, codeSize);
      table.clear();
      codeSize = kMinCodeSize + 1;
      next = kFirstFreeCode;
    }
    prefix = index;
  }
  emit(prefix);
  bits.put(kEndCode, codeSize);
  bits.flush();
  return packed;
}

}  // namespace

const std::array<std::array<uint8_t, 3>, kGifPaletteSize>& gifPalette() {
  return tables().colors;
}

uint8_t nearestGifColor(uint8_t r, uint8_t g, uint8_t b) {
  const PaletteTables& t = tables();
  // the nearest cube colour rounds each channel to its level; the nearest
  // grey comes from the mean; the nearer of the two wins
  const int cube = ((r + kCubeStep / 2) / kCubeStep) * 36 +
                   ((g + kCubeStep / 2) / kCubeStep) * 6 +
                   (b + kCubeStep / 2) / kCubeStep;
  const int grey = t.greyBySum[static_cast<size_t>(r + g + b)];
  const int cubeDistance =
      squaredDistance(t.colors[static_cast<size_t>(cube)], r, g, b);
  const int greyDistance =
      squaredDistance(t.colors[static_cast<size_t>(grey)], r, g, b);
  if (greyDistance < cubeDistance ||
      (greyDistance == cubeDistance && grey < cube))
    return static_cast<uint8_t>(grey);
  return static_cast<uint8_t>(cube);
}

GifEncoder::GifEncoder(int width, int height) : width_(width), height_(height) {
  VLN_CHECK_ARG(width >= 1 && width <= 65535 && height >= 1 && height <= 65535,
                "GifEncoder: width and height must be in 1..65535, got ", width,
                "x", height);
  // header and logical screen descriptor: global colour table of 2^(7+1)
  // entries, 8 bits per primary, background index 0, square pixels
  bytes_ = "GIF89a";
  putU16(bytes_, width);
  putU16(bytes_, height);
  bytes_.push_back(static_cast<char>(0xF7));
  bytes_.push_back('\0');
  bytes_.push_back('\0');
  for (const auto& c : gifPalette())
    bytes_.append(reinterpret_cast<const char*>(c.data()), 3);
  // NETSCAPE2.0 application extension: sub-block 1 = loop count, 0 = forever
  bytes_ += "\x21\xFF\x0B";
  bytes_ += "NETSCAPE2.0";
  bytes_ += "\x03\x01";
  putU16(bytes_, 0);
  bytes_.push_back('\0');
}

void GifEncoder::addFrame(std::span<const uint8_t> rgb, int delayCentiseconds) {
  VLN_CHECK_ARG(!finished_, "GifEncoder::addFrame(): the GIF is finished");
  VLN_CHECK_ARG(rgb.size() == static_cast<size_t>(width_) * height_ * 3,
                "GifEncoder::addFrame(): expected ", width_, "x", height_,
                "x3 = ", static_cast<size_t>(width_) * height_ * 3,
                " bytes of RGB, got ", rgb.size());
  VLN_CHECK_ARG(delayCentiseconds >= 0 && delayCentiseconds <= 65535,
                "GifEncoder::addFrame(): delay must be in 0..65535 "
                "centiseconds, got ",
                delayCentiseconds);
  // palette indices of the whole frame
  std::vector<uint8_t> indices(static_cast<size_t>(width_) * height_);
  for (size_t i = 0; i < indices.size(); ++i)
    indices[i] = nearestGifColor(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);

  // the rectangle to send: all of the first frame, then what changed
  int left = 0, top = 0, right = width_, bottom = height_;  // exclusive
  if (!previous_.empty()) {
    left = width_;
    top = height_;
    right = 0;
    bottom = 0;
    for (int y = 0; y < height_; ++y)
      for (int x = 0; x < width_; ++x) {
        const size_t i = static_cast<size_t>(y) * width_ + x;
        if (indices[i] == previous_[i]) continue;
        left = std::min(left, x);
        right = std::max(right, x + 1);
        top = std::min(top, y);
        bottom = std::max(bottom, y + 1);
      }
    if (right == 0) {  // nothing changed: one pixel, as it is
      left = top = 0;
      right = bottom = 1;
    }
  }
  std::vector<uint8_t> rectangle;
  rectangle.reserve(static_cast<size_t>(right - left) * (bottom - top));
  for (int y = top; y < bottom; ++y)
    for (int x = left; x < right; ++x) {
      const size_t i = static_cast<size_t>(y) * width_ + x;
      const bool same = !previous_.empty() && indices[i] == previous_[i];
      rectangle.push_back(same ? static_cast<uint8_t>(kGifTransparentIndex)
                               : indices[i]);
    }
  previous_ = std::move(indices);

  // graphic control extension: disposal 1 (leave the frame in place), no
  // user input, transparent colour kGifTransparentIndex
  bytes_ += "\x21\xF9\x04";
  bytes_.push_back(static_cast<char>((1 << 2) | 1));
  putU16(bytes_, delayCentiseconds);
  bytes_.push_back(static_cast<char>(kGifTransparentIndex));
  bytes_.push_back('\0');
  // image descriptor: the rectangle, global colour table, not interlaced
  bytes_.push_back(static_cast<char>(0x2C));
  putU16(bytes_, left);
  putU16(bytes_, top);
  putU16(bytes_, right - left);
  putU16(bytes_, bottom - top);
  bytes_.push_back('\0');

  // LZW codes, then sub-blocks of <= 255 bytes
  const std::string packed = lzwCompress(rectangle);
  bytes_.push_back(static_cast<char>(kMinCodeSize));
  for (size_t at = 0; at < packed.size(); at += 255) {
    const size_t n = std::min<size_t>(255, packed.size() - at);
    bytes_.push_back(static_cast<char>(n));
    bytes_.append(packed, at, n);
  }
  bytes_.push_back('\0');
  ++frames_;
}

std::string GifEncoder::finish() {
  VLN_CHECK_ARG(!finished_, "GifEncoder::finish(): the GIF is finished");
  VLN_CHECK_ARG(frames_ > 0, "GifEncoder::finish(): a GIF needs a frame");
  finished_ = true;
  previous_ = {};
  bytes_.push_back(static_cast<char>(0x3B));
  return std::move(bytes_);
}

std::string encodeGif(std::span<const uint8_t> rgb, int width, int height) {
  GifEncoder gif(width, height);
  gif.addFrame(rgb, /*delayCentiseconds=*/0);
  return gif.finish();
}

}  // namespace vln::viz
