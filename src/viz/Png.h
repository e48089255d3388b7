#pragma once
// PNG encoding in memory (through OpenCV, private to viz), for pictures
// that go somewhere other than a file, e.g. TensorBoard image summaries.

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace vln::viz {

/// The PNG bytes of an 8-bit image: `pixels` is [height, width, channels]
/// row-major with channels 1 (grey), 3 (RGB) or 4 (RGBA). Throws
/// std::invalid_argument for a size mismatch and std::runtime_error when
/// encoding fails.
std::string encodePng(std::span<const uint8_t> pixels, int width, int height,
                      int channels = 3);

/// A decoded 8-bit image.
struct DecodedImage {
  int width = 0;
  int height = 0;
  int channels = 0;             ///< 1 (grey), 3 (RGB) or 4 (RGBA)
  std::vector<uint8_t> pixels;  ///< [height, width, channels] row-major
};

/// Decodes PNG `bytes` (for checks and tools). Throws std::runtime_error
/// when they are not a decodable 8-bit PNG.
DecodedImage decodePng(std::string_view bytes);

}  // namespace vln::viz
