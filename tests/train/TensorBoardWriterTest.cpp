// Tests of src/train/TensorBoardWriter.cpp and Crc32c.cpp: the standard
// CRC-32C check value, TFRecord framing decoded back with both CRCs, and a
// hand-checked protobuf encoding of one scalar event.

#include "train/TensorBoardWriter.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "support/TestPaths.h"
#include "train/Crc32c.h"

namespace vln::train {
namespace {

using ::testing::HasSubstr;

TEST(Crc32cTest, StandardCheckValues) {
  // RFC 3720 (iSCSI) appendix B.4 and the usual "123456789" check value
  EXPECT_EQ(crc32c("123456789"), 0xE3069283u);
  EXPECT_EQ(crc32c(std::string(32, '\0')), 0x8A9136AAu);
  EXPECT_EQ(crc32c(std::string(32, '\xff')), 0x62A8AB43u);
  // continuing a CRC equals one CRC over the concatenation
  EXPECT_EQ(crc32c("6789", crc32c("12345")), crc32c("123456789"));
}

TEST(Crc32cTest, MaskIsTensorFlowsRotateAndAdd) {
  const uint32_t crc = 0x12345678u;
  EXPECT_EQ(maskCrc32c(crc), ((crc >> 15) | (crc << 17)) + 0xa282ead8u);
  EXPECT_EQ(maskCrc32c(0), 0xa282ead8u);
}

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
