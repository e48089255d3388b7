// Tests of src/common/ZipIntegrity.cpp on two archives checked by Python's
// zipfile (tests/data_files/zip): mixed.zip (stored and deflated entries, as
// PyTorch writes) and zip64.zip (every size and offset in zip64 records),
// and on damaged copies of them.

#include "common/ZipIntegrity.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "common/FileIo.h"
#include "support/TestPaths.h"

namespace vln::common {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

std::string fixture(const std::string& name) {
  return readFile(test::testDataPath() / "zip" / name);
}

// the message verifyZipIntegrity() throws for `bytes` ("" when it passes)
std::string failure(const std::string& bytes) {
  try {
    verifyZipIntegrity(bytes, "archive.pth");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

// offset of the first byte of `needle` in `bytes`
size_t at(const std::string& bytes, const std::string& needle) {
  const size_t pos = bytes.find(needle);
  EXPECT_NE(pos, std::string::npos) << needle;
  return pos;
}

TEST(ZipIntegrityTest, StoredAndDeflatedEntriesPass) {
  const ZipSummary s = verifyZipIntegrity(fixture("mixed.zip"), "mixed.zip");
  EXPECT_EQ(s.entries, 3);
  // 20 x "stored bytes " + 30 x a 32-byte line + "3\n" (the generator)
  EXPECT_EQ(s.uncompressed_bytes, 260 + 960 + 2);
}

TEST(ZipIntegrityTest, Zip64RecordsPass) {
  const ZipSummary s = verifyZipIntegrity(fixture("zip64.zip"), "zip64.zip");
  EXPECT_EQ(s.entries, 2);
  EXPECT_EQ(s.uncompressed_bytes, 1024 + 5);
}

TEST(ZipIntegrityTest, FlippedStoredByteNamesTheEntry) {
  std::string bytes = fixture("mixed.zip");
  bytes[at(bytes, "stored bytes") + 3] ^= 0x20;
  EXPECT_THAT(failure(bytes),
              AllOf(HasSubstr("'archive.pth' is not an intact zip archive"),
                    HasSubstr("entry 'archive/data.pkl' has CRC-32")));
}

TEST(ZipIntegrityTest, FlippedDeflatedByteIsCaught) {
  std::string bytes = fixture("mixed.zip");
  // the deflate stream follows the entry's local header and name
  const size_t data = at(bytes, "archive/code/__torch__.py") +
                      std::string("archive/code/__torch__.py").size();
  bytes[data + 10] ^= 0x01;
  EXPECT_THAT(failure(bytes), HasSubstr("entry 'archive/code/__torch__.py'"));
}

TEST(ZipIntegrityTest, FlippedZip64ByteIsCaught) {
  std::string bytes = fixture("zip64.zip");
  bytes[at(bytes, "hello")] = 'j';
  EXPECT_THAT(failure(bytes), HasSubstr("entry 'small.txt' has CRC-32"));
}

TEST(ZipIntegrityTest, TruncatedArchiveIsRefused) {
  const std::string bytes = fixture("mixed.zip");
  // without its end record, then cut inside the central directory
  EXPECT_THAT(failure(bytes.substr(0, bytes.size() - 10)),
              HasSubstr("no end-of-central-directory record"));
  EXPECT_THAT(failure(bytes.substr(0, 100)),
              HasSubstr("no end-of-central-directory record"));
  EXPECT_THAT(failure(""), HasSubstr("fewer than an end record"));
}

TEST(ZipIntegrityTest, LocalHeaderMustAgreeWithTheDirectory) {
  std::string bytes = fixture("mixed.zip");
  // the first occurrence of a name is its local header
  bytes[at(bytes, "archive/version") + 8] = 'X';
  EXPECT_THAT(
      failure(bytes),
      HasSubstr("its local header disagrees with the central directory"));
}

TEST(ZipIntegrityTest, EncryptedAndUnknownMethodsAreRefused) {
  const std::string good = fixture("mixed.zip");
  // central header of the first entry: flags at +8, method at +10
  const size_t central = good.find(std::string("PK\x01\x02", 4));
  ASSERT_NE(central, std::string::npos);
  std::string encrypted = good;
  encrypted[central + 8] |= 1;
  EXPECT_THAT(failure(encrypted), HasSubstr("is encrypted"));
  std::string bzip2 = good;  // in both headers: the local one opens the file
  bzip2[central + 10] = 12;
  bzip2[8] = 12;
  EXPECT_THAT(failure(bzip2), HasSubstr("compression method 12"));
}

TEST(ZipIntegrityTest, ReadZipEntriesReturnsStoredAndDeflatedData) {
  const std::vector<ZipEntry> entries =
      readZipEntries(fixture("mixed.zip"), "mixed.zip");
  ASSERT_EQ(entries.size(), 3u);
  EXPECT_EQ(entries[0].name, "archive/data.pkl");
  EXPECT_EQ(entries[0].data.size(), 260u);
  EXPECT_EQ(entries[0].data.substr(0, 13), "stored bytes ");
  EXPECT_EQ(entries[1].name, "archive/code/__torch__.py");
  EXPECT_EQ(entries[1].data.size(), 960u);  // inflated
  EXPECT_EQ(entries[2].data, "3\n");
  const auto zip64 = readZipEntries(fixture("zip64.zip"), "zip64.zip");
  ASSERT_EQ(zip64.size(), 2u);
  EXPECT_EQ(zip64[0].data.size() + zip64[1].data.size(), 1024u + 5u);
}

TEST(ZipIntegrityTest, ReadZipEntriesRefusesArchivesBeyondItsLimits) {
  const std::string bytes = fixture("mixed.zip");
  const auto refused = [&](const ZipReadLimits& limits) {
    try {
      readZipEntries(bytes, "bomb.zip", limits);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_THAT(refused({.max_entries = 2}),
              AllOf(HasSubstr("'bomb.zip'"),
                    HasSubstr("3 entries, more than the 2 allowed")));
  // checked on the recorded sizes, before the deflated entry is inflated
  EXPECT_THAT(refused({.max_total_bytes = 1000}),
              AllOf(HasSubstr("entry 'archive/code/__torch__.py'"),
                    HasSubstr("1220 uncompressed bytes, more than the 1000")));
  EXPECT_EQ(refused({.max_total_bytes = 1222}), "");
  // damage is still caught while reading
  std::string flipped = bytes;
  flipped[at(flipped, "stored bytes") + 3] ^= 0x20;
  EXPECT_THAT(
      [&] { readZipEntries(flipped, "x.zip"); },
      ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("CRC-32")));
}

TEST(ZipIntegrityTest, NotAZipIsRefused) {
  EXPECT_THAT(failure(std::string(64, 'a')),
              HasSubstr("no end-of-central-directory record"));
}

}  // namespace
}  // namespace vln::common
