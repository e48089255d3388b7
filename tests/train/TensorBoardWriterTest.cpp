// Tests of src/train/TensorBoardWriter.cpp (the CRC itself: Crc32cTest):
// TFRecord framing decoded back with both CRCs, a
// hand-checked protobuf encoding of one scalar event and of one image
// event, and image summaries (a PNG picture, an animated GIF video) read
// back and decoded (PNG through OpenCV, GIF with tests/support's decoder).

#include "train/TensorBoardWriter.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "support/GifDecoder.h"
#include "support/TestPaths.h"
#include "train/Crc32c.h"
#include "viz/Gif.h"
#include "viz/Image.h"

namespace vln::train {
namespace {

using ::testing::HasSubstr;

TEST(TensorBoardWriterTest, ScalarEventBytesMatchTheProtobufEncoding) {
  // Event{wall_time: 1.5, step: 300, summary{value{tag: "a", simple_value: 2}}}
  const std::string event = encodeScalarEvent(1.5, 300, {{"a", 2.0}});
  std::string expected;
  expected += '\x09';  // field 1, fixed64
  const double wall = 1.5;
  expected.append(reinterpret_cast<const char*>(&wall), 8);
  expected += "\x10\xac\x02";  // field 2 varint 300
  expected += "\x2a\x0a";      // field 5, 10 bytes
  expected += "\x0a\x08";      // Summary.value, 8 bytes
  expected +=
      "\x0a\x01"
      "a";             // tag
  expected += '\x15';  // simple_value, fixed32
  const float two = 2.0f;
  expected.append(reinterpret_cast<const char*>(&two), 4);
  EXPECT_EQ(event, expected);
}

TEST(TensorBoardWriterTest, FileDecodesWithValidCrcs) {
  test::TempDir dir;
  std::filesystem::path file;
  {
    TensorBoardWriter writer(dir / "tb");
    file = writer.file();
    writer.addScalar("train/loss", 0.75, 1);
    writer.addScalars(2, {{"train/loss", 0.5}, {"train/action_loss", 0.25}},
                      1234.0);
  }
  EXPECT_THAT(file.filename().string(),
              ::testing::StartsWith("events.out.tfevents."));
  TensorBoardFile decoded = readTensorBoardFile(file);
  EXPECT_EQ(decoded.file_version, "brain.Event:2");
  ASSERT_EQ(decoded.scalars.size(), 3u);
  EXPECT_EQ(decoded.scalars[0].tag, "train/loss");
  EXPECT_EQ(decoded.scalars[0].step, 1);
  EXPECT_FLOAT_EQ(decoded.scalars[0].value, 0.75f);
  EXPECT_EQ(decoded.scalars[2].tag, "train/action_loss");
  EXPECT_EQ(decoded.scalars[2].step, 2);
  EXPECT_DOUBLE_EQ(decoded.scalars[2].wall_time, 1234.0);

  // framing: the first record's length field and its masked CRC
  std::ifstream in(file, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)),
                    std::istreambuf_iterator<char>());
  uint64_t length = 0;
  std::memcpy(&length, bytes.data(), 8);
  uint32_t lengthCrc = 0;
  std::memcpy(&lengthCrc, bytes.data() + 8, 4);
  EXPECT_EQ(lengthCrc, maskCrc32c(crc32c(bytes.substr(0, 8))));
  uint32_t dataCrc = 0;
  std::memcpy(&dataCrc, bytes.data() + 12 + length, 4);
  EXPECT_EQ(dataCrc, maskCrc32c(crc32c(bytes.substr(12, length))));
}

TEST(TensorBoardWriterTest, ImageEventBytesMatchTheProtobufEncoding) {
  // Event{wall_time: 2, step: 7, summary{value{tag: "m", image{height: 2,
  // width: 3, colorspace: 3, encoded_image_string: "PNG!"}}}}
  const std::string event = encodeImageEvent(2.0, 7, "m", "PNG!", 3, 2, 3);
  std::string expected;
  expected += '\x09';
  const double wall = 2.0;
  expected.append(reinterpret_cast<const char*>(&wall), 8);
  expected += "\x10\x07";                  // step 7
  expected += "\x2a\x13";                  // field 5, 19 bytes
  expected += "\x0a\x11";                  // Summary.value, 17 bytes
  expected += "\x0a\x01m";                 // tag
  expected += "\x22\x0c";                  // Value.image (field 4), 12 bytes
  expected += "\x08\x02\x10\x03\x18\x03";  // height 2, width 3, colorspace 3
  expected += "\x22\x04PNG!";              // encoded_image_string
  EXPECT_EQ(event, expected);
}

TEST(TensorBoardWriterTest, ImagesAndVideosDecodeWithValidCrcs) {
  // a 5 x 4 RGB picture and a 3-frame 6 x 2 video of palette colours
  std::vector<uint8_t> picture(5 * 4 * 3);
  for (size_t i = 0; i < picture.size(); ++i)
    picture[i] = static_cast<uint8_t>(i * 13);
  const std::string png = viz::encodePng(viz::Image{5, 4, picture});
  viz::GifEncoder gif(6, 2);
  std::vector<std::vector<uint8_t>> frames;
  for (int f = 0; f < 3; ++f) {
    std::vector<uint8_t> frame;
    for (int p = 0; p < 12; ++p) {
      const auto& c = viz::gifPalette()[static_cast<size_t>(
          (p * 7 + f * 50) % viz::kGifTransparentIndex)];
      frame.insert(frame.end(), c.begin(), c.end());
    }
    gif.addFrame(frame, 25);
    frames.push_back(frame);
  }
  const std::string video = gif.finish();

  test::TempDir dir;
  std::filesystem::path file;
  {
    TensorBoardWriter writer(dir.path());
    file = writer.file();
    writer.addScalar("eval/val_seen/spl", 0.5, 3);
    writer.addImage("eval/val_seen/map/episode_7", 3, png, 5, 4, 3);
    writer.addImage("eval/val_seen/video/episode_7", 3, video, 6, 2, 3, 99.0);
    EXPECT_THAT(
        [&] { writer.addImage("x", 0, png, 5, 4, 2); },
        ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("'x'")));
  }
  // every record's CRCs are checked by the reader
  const TensorBoardFile decoded = readTensorBoardFile(file);
  ASSERT_EQ(decoded.scalars.size(), 1u);
  ASSERT_EQ(decoded.images.size(), 2u);
  const TensorBoardImage& map = decoded.images[0];
  EXPECT_EQ(map.tag, "eval/val_seen/map/episode_7");
  EXPECT_EQ(map.step, 3);
  EXPECT_EQ(map.width, 5);
  EXPECT_EQ(map.height, 4);
  EXPECT_EQ(map.colorspace, 3);
  const viz::Image image = viz::decodePng(map.encoded);
  EXPECT_EQ(image.width, 5);
  EXPECT_EQ(image.height, 4);
  EXPECT_EQ(image.rgb, picture);  // PNG is lossless

  const TensorBoardImage& clip = decoded.images[1];
  EXPECT_EQ(clip.tag, "eval/val_seen/video/episode_7");
  EXPECT_EQ(clip.step, 3);
  EXPECT_DOUBLE_EQ(clip.wall_time, 99.0);
  EXPECT_EQ(clip.width, 6);
  EXPECT_EQ(clip.height, 2);
  const vln::test::DecodedGif played = vln::test::decodeGif(clip.encoded);
  EXPECT_EQ(played.width, 6);
  EXPECT_EQ(played.height, 2);
  ASSERT_EQ(played.frames.size(), 3u);
  for (size_t f = 0; f < 3; ++f) {
    EXPECT_EQ(played.frames[f].rgb, frames[f]);
    EXPECT_EQ(played.frames[f].delay_cs, 25);
  }
}

TEST(TensorBoardWriterTest, CorruptedRecordIsReportedWithItsOffset) {
  test::TempDir dir;
  std::filesystem::path file;
  {
    TensorBoardWriter writer(dir.path());
    file = writer.file();
    writer.addScalar("x", 1.0, 0);
  }
  std::string bytes;
  {
    std::ifstream in(file, std::ios::binary);
    bytes.assign((std::istreambuf_iterator<char>(in)),
                 std::istreambuf_iterator<char>());
  }
  bytes[bytes.size() - 6] ^= 0x01;  // inside the last record's data
  {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out << bytes;
  }
  EXPECT_THAT([&] { readTensorBoardFile(file); },
              ::testing::ThrowsMessage<std::runtime_error>(
                  HasSubstr("data CRC mismatch")));
}

TEST(TensorBoardWriterTest, TwoWritersInOneSecondUseDistinctFiles) {
  test::TempDir dir;
  TensorBoardWriter a(dir.path());
  TensorBoardWriter b(dir.path());
  EXPECT_NE(a.file(), b.file());
}

}  // namespace
}  // namespace vln::train
