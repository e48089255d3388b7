#pragma once
// A small GIF87a/89a decoder for tests: checks the file's structure block
// by block and decodes every frame's LZW data back to palette indices, so
// tests can compare an encoder's output with the exact pixels it was given.
// Independent of src/viz/Gif.cpp (written from the GIF89a specification),
// so the two do not share a mistake.

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace vln::test {

struct GifFrame {
  int left = 0, top = 0, width = 0, height = 0;
  int delay_cs = 0;            ///< graphic control extension delay, 1/100 s
  int disposal = 0;            ///< graphic control extension disposal method
  int transparent_index = -1;  ///< -1: no transparent colour
  bool has_control = false;
  bool interlaced = false;
  int min_code_size = 0;
  /// Palette indices of the frame rectangle in the order transmitted:
  /// [height, width] row-major unless interlaced.
  std::vector<uint8_t> indices;
  /// The whole canvas after this frame, [screen height, width, 3] RGB
  /// (transparent pixels keep what was there; disposal methods other than
  /// 0 and 1 are not applied).
  std::vector<uint8_t> rgb;
  /// Clear codes met in the frame's data, the first one included.
  int clear_codes = 0;
  /// Widest code read, bits.
  int max_code_bits = 0;
};

struct DecodedGif {
  std::string version;  ///< "87a" or "89a"
  int width = 0, height = 0;
  std::vector<std::array<uint8_t, 3>> palette;  ///< the global colour table
  int loop_count = -1;  ///< NETSCAPE2.0 loop count; -1 when absent
  std::vector<GifFrame> frames;
};

/// Decodes `bytes`. Throws std::runtime_error naming the byte offset for a
/// bad signature, a truncated or unknown block, LZW data with an invalid
/// code, too few or too many pixels, or a missing trailer.
DecodedGif decodeGif(std::string_view bytes);

}  // namespace vln::test
