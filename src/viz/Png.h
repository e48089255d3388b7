#pragma once
// PNG encoding in memory (through OpenCV, private to viz), for pictures
// that go somewhere other than a file, e.g. TensorBoard image summaries.

#include <cstdint>
#include <span>
#include <string>

namespace vln::viz {

/// The PNG bytes of an 8-bit image: `pixels` is [height, width, channels]
/// row-major with channels 1 (grey), 3 (RGB) or 4 (RGBA). Throws
/// std::invalid_argument for a size mismatch and std::runtime_error when
/// encoding fails.
std::string encodePng(std::span<const uint8_t> pixels, int width, int height,
                      int channels = 3);

}  // namespace vln::viz
