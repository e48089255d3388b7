// Tests of src/viz/Gif.cpp, read back with the independent decoder of
// tests/support/GifDecoder.cpp: the file's blocks, exact pixels after LZW
// decoding (one frame, several frames, images long and noisy enough to
// widen the codes to 12 bits and clear the table, every length from 1 to
// 700 pixels so that the code width changes right at the end code), later
// frames sent as the rectangle that changed with the unchanged pixels
// transparent, and the nearest-colour mapping onto the fixed palette.

#include "viz/Gif.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "support/GifDecoder.h"

namespace vln::viz {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

// an RGB image of palette colours with the given indices
std::vector<uint8_t> paletteImage(const std::vector<uint8_t>& indices) {
  std::vector<uint8_t> rgb;
  for (uint8_t i : indices)
    rgb.insert(rgb.end(), gifPalette()[i].begin(), gifPalette()[i].end());
  return rgb;
}

std::vector<uint8_t> randomIndices(size_t n, uint64_t seed, int colors) {
  std::mt19937_64 rng(seed);
  std::vector<uint8_t> out(n);
  for (auto& v : out) v = static_cast<uint8_t>(rng() % colors);
  return out;
}

int squaredDistance(const std::array<uint8_t, 3>& c, int r, int g, int b) {
  return (c[0] - r) * (c[0] - r) + (c[1] - g) * (c[1] - g) +
         (c[2] - b) * (c[2] - b);
}

TEST(GifTest, SingleFrameHasTheBlocksAndExactPixels) {
  const int width = 37, height = 23;  // odd sizes
  const auto indices = randomIndices(static_cast<size_t>(width) * height, 1,
                                     kGifTransparentIndex);
  const std::vector<uint8_t> rgb = paletteImage(indices);
  const std::string bytes = encodeGif(rgb, width, height);
  ASSERT_EQ(bytes.substr(0, 6), "GIF89a");
  EXPECT_EQ(bytes.back(), '\x3B');

  const test::DecodedGif gif = test::decodeGif(bytes);
  EXPECT_EQ(gif.version, "89a");
  EXPECT_EQ(gif.width, width);
  EXPECT_EQ(gif.height, height);
  ASSERT_EQ(gif.palette.size(), 256u);
  for (int i = 0; i < kGifPaletteSize; ++i)
    EXPECT_EQ(gif.palette[static_cast<size_t>(i)],
              gifPalette()[static_cast<size_t>(i)]);
  EXPECT_EQ(gif.loop_count, 0);  // NETSCAPE2.0: loop forever
  ASSERT_EQ(gif.frames.size(), 1u);
  const test::GifFrame& frame = gif.frames[0];
  EXPECT_TRUE(frame.has_control);
  EXPECT_EQ(frame.disposal, 1);
  EXPECT_EQ(frame.left, 0);
  EXPECT_EQ(frame.top, 0);
  EXPECT_EQ(frame.width, width);
  EXPECT_EQ(frame.height, height);
  EXPECT_FALSE(frame.interlaced);
  EXPECT_EQ(frame.min_code_size, 8);
  EXPECT_EQ(frame.clear_codes, 1);  // the leading one only
  EXPECT_EQ(frame.indices, indices);
  EXPECT_EQ(frame.rgb, rgb);
}

TEST(GifTest, FramesKeepTheirPixelsAndDelays) {
  const int width = 16, height = 9;
  const size_t n = static_cast<size_t>(width) * height;
  GifEncoder encoder(width, height);
  std::vector<std::vector<uint8_t>> frames;
  // noise, one flat colour, a gradient of greys
  frames.push_back(paletteImage(randomIndices(n, 2, kGifTransparentIndex)));
  frames.push_back(paletteImage(std::vector<uint8_t>(n, 17)));
  std::vector<uint8_t> ramp(n);
  for (size_t i = 0; i < n; ++i) ramp[i] = static_cast<uint8_t>(216 + i % 39);
  frames.push_back(paletteImage(ramp));
  const std::vector<int> delays = {25, 0, 400};
  for (size_t k = 0; k < frames.size(); ++k)
    encoder.addFrame(frames[k], delays[k]);
  EXPECT_EQ(encoder.frames(), 3);
  const std::string bytes = encoder.finish();

  const test::DecodedGif gif = test::decodeGif(bytes);
  ASSERT_EQ(gif.frames.size(), 3u);
  for (size_t k = 0; k < frames.size(); ++k) {
    SCOPED_TRACE(k);
    EXPECT_EQ(gif.frames[k].delay_cs, delays[k]);
    EXPECT_EQ(gif.frames[k].rgb, frames[k]);
  }
}

TEST(GifTest, LaterFramesSendOnlyTheChangedRectangle) {
  const int width = 20, height = 12;
  const size_t n = static_cast<size_t>(width) * height;
  const auto base = randomIndices(n, 6, kGifTransparentIndex);
  // frame 1 changes pixels (3, 2) and (7, 5); frame 2 changes nothing
  auto changed = base;
  for (const int at : {2 * width + 3, 5 * width + 7})
    changed[at] = static_cast<uint8_t>((base[at] + 1) % kGifTransparentIndex);
  GifEncoder encoder(width, height);
  encoder.addFrame(paletteImage(base), 10);
  encoder.addFrame(paletteImage(changed), 10);
  encoder.addFrame(paletteImage(changed), 10);
  const test::DecodedGif gif = test::decodeGif(encoder.finish());
  ASSERT_EQ(gif.frames.size(), 3u);
  const test::GifFrame& whole = gif.frames[0];
  EXPECT_EQ(whole.left, 0);
  EXPECT_EQ(whole.top, 0);
  EXPECT_EQ(whole.width, width);
  EXPECT_EQ(whole.height, height);
  const test::GifFrame& box = gif.frames[1];
  EXPECT_EQ(box.left, 3);
  EXPECT_EQ(box.top, 2);
  EXPECT_EQ(box.width, 5);   // columns 3..7
  EXPECT_EQ(box.height, 4);  // rows 2..5
  // in it, the unchanged pixels are transparent
  EXPECT_EQ(box.transparent_index, kGifTransparentIndex);
  EXPECT_EQ(
      std::count(box.indices.begin(), box.indices.end(), kGifTransparentIndex),
      5 * 4 - 2);
  EXPECT_EQ(gif.frames[2].width * gif.frames[2].height, 1);
  // drawn over the previous frame, every frame shows exactly its pixels
  EXPECT_EQ(gif.frames[0].rgb, paletteImage(base));
  EXPECT_EQ(gif.frames[1].rgb, paletteImage(changed));
  EXPECT_EQ(gif.frames[2].rgb, paletteImage(changed));
}

TEST(GifTest, LongNoisyFramesWidenCodesAndClearTheTable) {
  // 255-colour noise adds a table entry for almost every pixel: 4096 codes
  // are used up after ~3,840 pixels, so 300 x 200 clears the table ~15 times
  const int width = 300, height = 200;
  const auto indices = randomIndices(static_cast<size_t>(width) * height, 3,
                                     kGifTransparentIndex);
  const test::DecodedGif gif =
      test::decodeGif(encodeGif(paletteImage(indices), width, height));
  ASSERT_EQ(gif.frames.size(), 1u);
  EXPECT_EQ(gif.frames[0].max_code_bits, 12);
  EXPECT_GT(gif.frames[0].clear_codes, 10);
  EXPECT_EQ(gif.frames[0].indices, indices);

  // few colours in long runs: codes grow through 9..12 bits on repeats
  // (the decoder's "code not yet in the table" case) and clear later
  std::vector<uint8_t> runs(static_cast<size_t>(width) * height);
  std::mt19937_64 rng(4);
  for (size_t i = 0; i < runs.size();) {
    const auto color = static_cast<uint8_t>(rng() % 4);
    const size_t length = 1 + rng() % 40;
    for (size_t k = 0; k < length && i < runs.size(); ++k) runs[i++] = color;
  }
  const test::DecodedGif few =
      test::decodeGif(encodeGif(paletteImage(runs), width, height));
  EXPECT_EQ(few.frames[0].indices, runs);
  EXPECT_GE(few.frames[0].max_code_bits, 10);
}

TEST(GifTest, EveryLengthDecodes) {
  // 1 x n noise images for n = 1..700: the codes widen to 10 bits after
  // the 255th code, so some lengths end exactly where the decoder widens
  // them before reading the end code
  for (int n = 1; n <= 700; ++n) {
    const auto indices =
        randomIndices(static_cast<size_t>(n), 100 + n, kGifTransparentIndex);
    const auto decoded =
        test::decodeGif(encodeGif(paletteImage(indices), n, 1));
    ASSERT_EQ(decoded.frames[0].indices, indices) << "length " << n;
  }
  // one flat colour of every length up to 3,000 (KwKwK codes only)
  for (int n = 1; n <= 3000; n += 7) {
    const std::vector<uint8_t> flat(static_cast<size_t>(n), 200);
    const auto decoded = test::decodeGif(encodeGif(paletteImage(flat), 1, n));
    ASSERT_EQ(decoded.frames[0].indices, flat) << "length " << n;
  }
}

TEST(GifTest, PaletteIsTheColourCubeAndGreys) {
  const auto& palette = gifPalette();
  EXPECT_EQ(palette[0], (std::array<uint8_t, 3>{0, 0, 0}));
  EXPECT_EQ(palette[215], (std::array<uint8_t, 3>{255, 255, 255}));
  EXPECT_EQ(palette[5 * 36 + 0 * 6 + 1], (std::array<uint8_t, 3>{255, 0, 51}));
  for (int i = 216; i < kGifTransparentIndex; ++i) {
    const auto& c = palette[static_cast<size_t>(i)];
    EXPECT_TRUE(c[0] == c[1] && c[1] == c[2]) << i;
    EXPECT_NE(c[0] % 51, 0) << i;  // not one of the cube's greys
  }
  EXPECT_EQ(kGifTransparentIndex, 255);
}

TEST(GifTest, ColoursMapToTheNearestPaletteEntry) {
  // palette colours map to themselves (the transparent entry is no colour)
  for (int i = 0; i < kGifTransparentIndex; ++i) {
    const auto& c = gifPalette()[static_cast<size_t>(i)];
    EXPECT_EQ(nearestGifColor(c[0], c[1], c[2]), i);
  }
  // any colour: no palette entry is nearer (brute force)
  std::mt19937_64 rng(5);
  for (int k = 0; k < 20000; ++k) {
    const auto r = static_cast<uint8_t>(rng());
    const auto g = k % 3 == 0 ? r : static_cast<uint8_t>(rng());
    const auto b = k % 3 == 0 ? r : static_cast<uint8_t>(rng());
    int best = 1 << 30;
    for (int i = 0; i < kGifTransparentIndex; ++i)
      best = std::min(
          best, squaredDistance(gifPalette()[static_cast<size_t>(i)], r, g, b));
    const uint8_t chosen = nearestGifColor(r, g, b);
    ASSERT_NE(chosen, kGifTransparentIndex);
    ASSERT_EQ(squaredDistance(gifPalette()[chosen], r, g, b), best)
        << int(r) << "," << int(g) << "," << int(b);
  }
  // an encoded frame shows each pixel's nearest colour
  const std::vector<uint8_t> rgb = {250, 10, 10, 128, 128, 128, 30, 200, 90};
  const auto decoded = test::decodeGif(encodeGif(rgb, 3, 1));
  for (int p = 0; p < 3; ++p)
    EXPECT_EQ(decoded.frames[0].indices[static_cast<size_t>(p)],
              nearestGifColor(rgb[3 * p], rgb[3 * p + 1], rgb[3 * p + 2]));
  EXPECT_EQ(decoded.frames[0].indices[0], 5 * 36);  // pure red
}

TEST(GifTest, BadSizesAndMisuseAreErrors) {
  EXPECT_THAT([] { GifEncoder(0, 4); },
              ThrowsMessage<std::invalid_argument>(HasSubstr("1..65535")));
  GifEncoder encoder(2, 2);
  EXPECT_THAT([&] { encoder.finish(); },
              ThrowsMessage<std::invalid_argument>(HasSubstr("needs a frame")));
  const std::vector<uint8_t> small(9, 0);
  EXPECT_THAT([&] { encoder.addFrame(small, 10); },
              ThrowsMessage<std::invalid_argument>(HasSubstr("got 9")));
  const std::vector<uint8_t> frame(12, 0);
  EXPECT_THAT([&] { encoder.addFrame(frame, -1); },
              ThrowsMessage<std::invalid_argument>(HasSubstr("delay")));
  encoder.addFrame(frame, 10);
  encoder.finish();
  EXPECT_THAT([&] { encoder.addFrame(frame, 10); },
              ThrowsMessage<std::invalid_argument>(HasSubstr("finished")));
}

TEST(GifTest, DecoderRejectsCorruptFiles) {
  const std::vector<uint8_t> rgb(3 * 64 * 64, 90);
  std::string bytes = encodeGif(rgb, 64, 64);
  EXPECT_THAT([&] { test::decodeGif(bytes.substr(0, bytes.size() - 1)); },
              ThrowsMessage<std::runtime_error>(HasSubstr("end of file")));
  EXPECT_THAT([&] { test::decodeGif("PNG..." + bytes.substr(6)); },
              ThrowsMessage<std::runtime_error>(HasSubstr("signature")));
}

}  // namespace
}  // namespace vln::viz
