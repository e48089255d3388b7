#pragma once
// Animated GIF89a, encoded by hand (no dependency): what TensorBoard shows
// as a video in its image tab (tensorboardX's add_video writes the same).
//
// Layout written (GIF89a specification, https://www.w3.org/Graphics/GIF/
// spec-gif89a.txt):
//   "GIF89a", logical screen descriptor (width, height, a 256-entry global
//   colour table), the table (gifPalette()), the NETSCAPE2.0 application
//   extension (loop forever), then per frame a graphic control extension
//   (delay in 1/100 s, disposal "do not dispose", transparent index
//   kGifTransparentIndex), an image descriptor and the LZW-compressed
//   colour indices (minimum code size 8, codes of 9 to 12 bits, a clear
//   code whenever the 4096-entry table is full) in sub-blocks of at most
//   255 bytes; finally the trailer 0x3B. The first frame covers the whole
//   screen; each later one only the smallest rectangle holding the pixels
//   that changed, in which unchanged pixels are transparent (the previous
//   frame, which "do not dispose" keeps, shows through), at least 1 x 1.
//   Long runs of transparent pixels compress well, so a video whose map and
//   caption change little costs mostly its camera panels.
//
// Colours: one fixed palette for every frame (no per-frame quantisation):
// the 6x6x6 colour cube (levels 0, 51, ..., 255), 39 greys between the
// cube's grey levels, and the transparent entry. Every pixel takes the
// palette colour nearest to it (Euclidean RGB distance), so palette colours
// are exact and flat drawings (maps, depth in grey) stay clean.

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace vln::viz {

/// Entries of the palette.
inline constexpr int kGifPaletteSize = 256;

/// The index that stands for "unchanged" in later frames (never a colour
/// of an image; its table entry is black).
inline constexpr int kGifTransparentIndex = 255;

/// The palette: entry i is RGB (palette[i][0..2]); entries 0-215 are the
/// colour cube, r * 36 + g * 6 + b for levels r, g, b in 0..5 (x51),
/// 216-254 are greys and 255 is kGifTransparentIndex.
const std::array<std::array<uint8_t, 3>, kGifPaletteSize>& gifPalette();

/// Index of the palette colour nearest to (r, g, b) (Euclidean RGB
/// distance; ties go to the lower index), never kGifTransparentIndex.
uint8_t nearestGifColor(uint8_t r, uint8_t g, uint8_t b);

/// Builds an animated GIF in memory, frame by frame (each frame is
/// compressed as it arrives, so memory holds the file, not the frames).
class GifEncoder {
 public:
  /// A GIF of `width` x `height` pixels (1..65535 each; std::invalid_argument
  /// otherwise) that loops forever.
  GifEncoder(int width, int height);

  /// Appends a frame: `rgb` is [height, width, 3] uint8, row-major, shown
  /// for `delayCentiseconds` (0..65535) hundredths of a second. Throws
  /// std::invalid_argument for a wrong size or delay, or after finish().
  void addFrame(std::span<const uint8_t> rgb, int delayCentiseconds);

  /// Appends the trailer and returns the file's bytes; the encoder is done
  /// afterwards. A GIF needs at least one frame (std::invalid_argument).
  std::string finish();

  int width() const { return width_; }
  int height() const { return height_; }
  /// Frames added so far.
  int frames() const { return frames_; }
  /// Bytes encoded so far (the trailer not counted).
  size_t size() const { return bytes_.size(); }

 private:
  int width_;
  int height_;
  int frames_ = 0;
  bool finished_ = false;
  std::string bytes_;
  std::vector<uint8_t> previous_;  ///< palette indices of the last frame
};

/// A one-frame GIF of an RGB image ([height, width, 3] uint8).
std::string encodeGif(std::span<const uint8_t> rgb, int width, int height);

}  // namespace vln::viz
