#include "support/GifDecoder.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

namespace vln::test {
namespace {

[[noreturn]] void fail(size_t offset, const std::string& what) {
  throw std::runtime_error("decodeGif(): byte " + std::to_string(offset) +
                           ": " + what);
}

// a cursor over the file
struct Cursor {
  std::string_view bytes;
  size_t at = 0;
  uint8_t u8() {
    if (at >= bytes.size()) fail(at, "unexpected end of file");
    return static_cast<uint8_t>(bytes[at++]);
  }
  int u16() {
    const int lo = u8();
    return lo | (u8() << 8);
  }
  std::string_view take(size_t n) {
    if (at + n > bytes.size()) fail(at, "unexpected end of file");
    std::string_view out = bytes.substr(at, n);
    at += n;
    return out;
  }
  // a chain of data sub-blocks up to the zero-length terminator
  std::string subBlocks() {
    std::string data;
    for (int n = u8(); n != 0; n = u8()) data += take(static_cast<size_t>(n));
    return data;
  }
};

std::vector<std::array<uint8_t, 3>> colorTable(Cursor& in, int sizeField) {
  std::vector<std::array<uint8_t, 3>> table(size_t{1} << (sizeField + 1));
  for (auto& c : table) c = {in.u8(), in.u8(), in.u8()};
  return table;
}

// LZW decoding of one frame's data (GIF89a appendix F): the code width
// starts at minCodeSize + 1 and grows when the next free code reaches
// 2^width (at most 12 bits); entries stop at 4096 until a clear code
std::vector<uint8_t> lzwDecode(const std::string& data, int minCodeSize,
                               size_t pixels, size_t offset, GifFrame& frame) {
  if (minCodeSize < 2 || minCodeSize > 8)
    fail(offset, "LZW minimum code size " + std::to_string(minCodeSize));
  const int clear = 1 << minCodeSize;
  const int end = clear + 1;
  std::vector<int> prefix(4096, -1);
  std::vector<uint8_t> suffix(4096, 0), first(4096, 0);
  for (int i = 0; i < clear; ++i) {
    suffix[static_cast<size_t>(i)] = static_cast<uint8_t>(i);
    first[static_cast<size_t>(i)] = static_cast<uint8_t>(i);
  }
  int width = minCodeSize + 1;
  int next = end + 1;
  int previous = -1;
  size_t bit = 0;
  std::vector<uint8_t> out;
  std::vector<uint8_t> string;
  auto read = [&]() {
    if (bit + static_cast<size_t>(width) > data.size() * 8)
      fail(offset, "LZW data ends without an end code");
    int code = 0;
    for (int k = 0; k < width; ++k, ++bit)
      code |= ((static_cast<uint8_t>(data[bit / 8]) >> (bit % 8)) & 1) << k;
    frame.max_code_bits = std::max(frame.max_code_bits, width);
    return code;
  };
  auto append = [&](int code) {
    string.clear();
    for (int c = code; c >= 0; c = prefix[static_cast<size_t>(c)])
      string.push_back(suffix[static_cast<size_t>(c)]);
    out.insert(out.end(), string.rbegin(), string.rend());
  };
  for (;;) {
    const int code = read();
    if (code == clear) {
      ++frame.clear_codes;
      width = minCodeSize + 1;
      next = end + 1;
      previous = -1;
      continue;
    }
    if (code == end) break;
    if (previous < 0) {
      if (code >= clear)
        fail(offset, "LZW code " + std::to_string(code) + " after a clear");
      append(code);
      previous = code;
      continue;
    }
    if (code > next || (code == next && next >= 4096))
      fail(offset, "LZW code " + std::to_string(code) + " beyond the table (" +
                       std::to_string(next) + " entries)");
    // a known code adds previous + its first index; the code being defined
    // (KwKwK) is previous + previous's first index
    const uint8_t head = code < next ? first[static_cast<size_t>(code)]
                                     : first[static_cast<size_t>(previous)];
    if (next < 4096) {
      prefix[static_cast<size_t>(next)] = previous;
      suffix[static_cast<size_t>(next)] = head;
      first[static_cast<size_t>(next)] = first[static_cast<size_t>(previous)];
      ++next;
      if (next == (1 << width) && width < 12) ++width;
    }
    append(code);
    previous = code;
  }
  // what follows the end code is at most the padding of its last byte
  if ((bit + 7) / 8 != data.size())
    fail(offset, std::to_string(data.size() - (bit + 7) / 8) +
                     " bytes of LZW data after the end code");
  if (out.size() != pixels)
    fail(offset, "LZW data holds " + std::to_string(out.size()) +
                     " pixels, the frame " + std::to_string(pixels));
  return out;
}

}  // namespace

DecodedGif decodeGif(std::string_view bytes) {
  Cursor in{bytes};
  DecodedGif gif;
  const std::string_view signature = in.take(6);
  if (signature != "GIF89a" && signature != "GIF87a")
    fail(0, "not a GIF signature");
  gif.version = std::string(signature.substr(3));

  // logical screen descriptor and global colour table
  gif.width = in.u16();
  gif.height = in.u16();
  const uint8_t packed = in.u8();
  in.u8();  // background colour index
  in.u8();  // pixel aspect ratio
  if (packed & 0x80) gif.palette = colorTable(in, packed & 0x07);
  std::vector<uint8_t> canvas(static_cast<size_t>(gif.width) * gif.height * 3,
                              0);

  GifFrame pending;
  for (;;) {
    const size_t blockAt = in.at;
    const uint8_t introducer = in.u8();
    if (introducer == 0x3B) break;  // trailer
    if (introducer == 0x21) {
      const uint8_t label = in.u8();
      if (label == 0xF9) {
        // graphic control extension
        if (in.u8() != 4) fail(blockAt, "graphic control block size");
        const uint8_t fields = in.u8();
        pending.disposal = (fields >> 2) & 0x07;
        pending.delay_cs = in.u16();
        const uint8_t transparent = in.u8();
        pending.transparent_index = (fields & 1) ? transparent : -1;
        if (in.u8() != 0) fail(blockAt, "graphic control terminator");
        pending.has_control = true;
      } else if (label == 0xFF) {
        // application extension: NETSCAPE2.0 carries the loop count
        if (in.u8() != 11) fail(blockAt, "application block size");
        const std::string_view id = in.take(11);
        const std::string data = in.subBlocks();
        if (id == "NETSCAPE2.0") {
          if (data.size() != 3 || data[0] != 1)
            fail(blockAt, "NETSCAPE2.0 loop block");
          gif.loop_count = static_cast<uint8_t>(data[1]) |
                           (static_cast<uint8_t>(data[2]) << 8);
        }
      } else if (label == 0xFE || label == 0x01) {
        in.subBlocks();  // comment, plain text
      } else {
        fail(blockAt, "unknown extension label " + std::to_string(label));
      }
      continue;
    }
    if (introducer != 0x2C)
      fail(blockAt, "unknown block introducer " + std::to_string(introducer));

    // image descriptor, optional local colour table, LZW data
    GifFrame frame = pending;
    pending = GifFrame{};
    frame.left = in.u16();
    frame.top = in.u16();
    frame.width = in.u16();
    frame.height = in.u16();
    const uint8_t fields = in.u8();
    frame.interlaced = (fields & 0x40) != 0;
    if (frame.left + frame.width > gif.width ||
        frame.top + frame.height > gif.height)
      fail(blockAt, "frame outside the logical screen");
    const auto palette =
        (fields & 0x80) ? colorTable(in, fields & 0x07) : gif.palette;
    if (palette.empty()) fail(blockAt, "frame without a colour table");
    frame.min_code_size = in.u8();
    const std::string data = in.subBlocks();
    const size_t count = static_cast<size_t>(frame.width) * frame.height;
    frame.indices = lzwDecode(data, frame.min_code_size, count, blockAt, frame);
    // interlaced rows come in passes 0, 4, 2, 1 (every 8th, 8th, 4th, 2nd)
    std::vector<int> rowOrder;
    if (frame.interlaced) {
      for (auto [start, step] : {std::pair{0, 8}, {4, 8}, {2, 4}, {1, 2}})
        for (int row = start; row < frame.height; row += step)
          rowOrder.push_back(row);
    } else {
      for (int row = 0; row < frame.height; ++row) rowOrder.push_back(row);
    }
    for (int k = 0; k < frame.height; ++k)
      for (int x = 0; x < frame.width; ++x) {
        const uint8_t index =
            frame.indices[static_cast<size_t>(k) * frame.width + x];
        if (index == frame.transparent_index) continue;
        if (index >= palette.size())
          fail(blockAt,
               "index " + std::to_string(index) + " beyond the colour table");
        const size_t at =
            (static_cast<size_t>(frame.top + rowOrder[static_cast<size_t>(k)]) *
                 gif.width +
             frame.left + x) *
            3;
        for (int c = 0; c < 3; ++c) canvas[at + c] = palette[index][c];
      }
    frame.rgb = canvas;
    gif.frames.push_back(std::move(frame));
  }
  if (in.at != bytes.size())
    fail(in.at,
         std::to_string(bytes.size() - in.at) + " bytes after the trailer");
  if (gif.frames.empty()) fail(in.at, "no image");
  return gif;
}

}  // namespace vln::test
