#include "train/Crc32c.h"

#include <gtest/gtest.h>

#include <random>
#include <string>

namespace vln::train {
namespace {

TEST(Crc32cTest, StandardCheckValues) {
  // RFC 3720 (iSCSI) appendix B.4 and the usual "123456789" check value
  EXPECT_EQ(crc32c("123456789"), 0xE3069283u);
  EXPECT_EQ(crc32c(std::string(32, '\0')), 0x8A9136AAu);
  EXPECT_EQ(crc32c(std::string(32, '\xff')), 0x62A8AB43u);
  EXPECT_EQ(crc32cPortable("123456789"), 0xE3069283u);
  EXPECT_EQ(crc32cPortable(std::string(32, '\xff')), 0x62A8AB43u);
  // continuing a CRC equals one CRC over the concatenation
  EXPECT_EQ(crc32c("6789", crc32c("12345")), crc32c("123456789"));
  EXPECT_EQ(crc32c(""), 0u);
}

// the instruction path (8 bytes at a time, then a byte tail) against the
// table, over every tail length, unaligned starts and continued CRCs
TEST(Crc32cTest, InstructionPathEqualsTheTable) {
  std::mt19937 rng(7);
  std::string bytes(4096 + 17, '\0');
  for (char& b : bytes) b = static_cast<char>(rng() & 0xFFu);
  for (size_t offset = 0; offset < 9; ++offset)
    for (size_t length : {0, 1, 7, 8, 9, 15, 16, 63, 64, 65, 1000, 4096}) {
      const std::string_view data(bytes.data() + offset, length);
      const uint32_t start = static_cast<uint32_t>(rng());
      EXPECT_EQ(crc32c(data), crc32cPortable(data))
          << "offset " << offset << ", length " << length;
      EXPECT_EQ(crc32c(data, start), crc32cPortable(data, start))
          << "offset " << offset << ", length " << length;
    }
}

TEST(Crc32cTest, MaskIsTensorFlowsRotateAndAdd) {
  const uint32_t crc = 0x12345678u;
  EXPECT_EQ(maskCrc32c(crc), ((crc >> 15) | (crc << 17)) + 0xa282ead8u);
  EXPECT_EQ(maskCrc32c(0), 0xa282ead8u);
}

}  // namespace
}  // namespace vln::train
