#pragma once
// An RGB picture in memory, and its encodings: what maps, report frames and
// TensorBoard images are passed around as.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace vln::viz {

/// [height, width, 3] RGB, 8 bits per channel, row-major.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> rgb;
};

/// PNG bytes of `image`. Throws std::invalid_argument when the pixel buffer
/// does not match the size.
std::string encodePng(const Image& image);
/// The image in PNG `bytes` as RGB (grey and alpha converted), for checks
/// and tools. Throws std::runtime_error when they are not a decodable PNG.
Image decodePng(std::string_view bytes);
/// JPEG bytes at `quality` (1-100).
std::string encodeJpeg(const Image& image, int quality = 85);
/// Writes the PNG atomically; std::runtime_error names the file on failure.
void savePng(const Image& image, const std::filesystem::path& file);
/// `image` scaled to `width` x `height` (area averaging when shrinking,
/// nearest neighbour when enlarging, so small observations stay crisp).
Image resizeImage(const Image& image, int width, int height);

}  // namespace vln::viz
