#include "common/FileIo.h"

#include <gmock/gmock.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <gtest/gtest.h>

#include "common/Json.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::common {
namespace {

using ::testing::HasSubstr;

TEST(FileIoTest, GzipRoundTripAndDetection) {
  test::TempDir dir;
  std::string text(100000, 'a');
  for (size_t i = 0; i < text.size(); i += 7) text[i] = static_cast<char>('a' + i % 26);
  writeFileAtomic(dir / "x.txt.gz", text);
  writeFileAtomic(dir / "x.txt", text);
  EXPECT_EQ(readFile(dir / "x.txt.gz"), text);
  EXPECT_EQ(readFile(dir / "x.txt"), text);
  EXPECT_LT(std::filesystem::file_size(dir / "x.txt.gz"), text.size());
}

TEST(FileIoTest, TruncatedGzipIsAnErrorNamingTheFile) {
  test::TempDir dir;
  std::string packed = gzipCompress(std::string(5000, 'z') + "tail");
  test::writeText(dir / "t.json.gz", packed.substr(0, packed.size() / 2));
  EXPECT_THAT([&] { readFile(dir / "t.json.gz"); },
              ::testing::ThrowsMessage<std::runtime_error>(
                  HasSubstr("t.json.gz' is a truncated gzip stream")));
  EXPECT_THAT([&] { readFile(dir / "missing.json"); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("missing.json")));
}

TEST(FileIoTest, AtomicWriteKeepsNoTemporaries) {
  test::TempDir dir;
  writeFileAtomic(dir / "sub" / "a.json", "{}");
  writeFileAtomic(dir / "sub" / "a.json", "{\"k\": 1}");
  EXPECT_EQ(test::countEntries(dir / "sub"), 1);
  EXPECT_EQ(readJsonFile(dir / "sub" / "a.json")["k"], 1);
}

TEST(FileIoTest, StaleTemporariesOfDeadWritersAreRemoved) {
  test::TempDir dir;
  // a child that exits is a writer killed mid-write: its pid is free after
  // the wait (and not reused this quickly)
  const pid_t dead = ::fork();
  ASSERT_GE(dead, 0);
  if (dead == 0) ::_exit(0);
  ASSERT_EQ(::waitpid(dead, nullptr, 0), dead);
  const std::string deadTag = ".tmp." + std::to_string(dead) + ".3";
  const std::string liveTag = ".tmp." + std::to_string(::getpid()) + ".0";
  test::writeText(dir / ("ckpt.2.pth" + deadTag), "half");
  test::writeText(dir / "checkpoints" / ("best.json" + deadTag), "{");
  test::writeText(dir / ("metrics.jsonl" + liveTag), "in flight");
  test::writeText(dir / "notes.tmp.txt", "not a temporary");
  test::writeText(dir / "ckpt.1.pth", "kept");

  auto removed = removeStaleTemporaries(dir.path());
  std::sort(removed.begin(), removed.end());
  EXPECT_EQ(removed, (std::vector<std::filesystem::path>{
                         dir / "checkpoints" / ("best.json" + deadTag),
                         dir / ("ckpt.2.pth" + deadTag)}));
  EXPECT_FALSE(std::filesystem::exists(dir / ("ckpt.2.pth" + deadTag)));
  EXPECT_TRUE(std::filesystem::exists(dir / ("metrics.jsonl" + liveTag)));
  EXPECT_TRUE(std::filesystem::exists(dir / "notes.tmp.txt"));
  EXPECT_TRUE(std::filesystem::exists(dir / "ckpt.1.pth"));
  EXPECT_TRUE(removeStaleTemporaries(dir / "missing").empty());
}

// writeFileUnsynced() + syncFileSystem(): a folder's files written without
// a sync each (parents created, the name as given, no temporaries), then
// synced once; failures name the path
TEST(FileIoTest, UnsyncedWritesThenOneSync) {
  vln::test::TempDir dir;
  writeFileUnsynced(dir / "a" / "b" / "frame.png", "bytes");
  writeFileUnsynced(dir / "a" / "b" / "frame.png", "new");
  EXPECT_EQ(readFile(dir / "a" / "b" / "frame.png"), "new");
  EXPECT_EQ(vln::test::countEntries(dir / "a" / "b"), 1);
  EXPECT_NO_THROW(syncFileSystem(dir / "a"));
  EXPECT_THAT(vln::test::errorOf([&] { syncFileSystem(dir / "missing"); }),
              HasSubstr("syncFileSystem(): cannot open '" +
                        (dir / "missing").string() + "'"));
  vln::test::writeText(dir / "file", "x");
  EXPECT_THAT(
      vln::test::errorOf([&] { writeFileUnsynced(dir / "file" / "f", "x"); }),
      HasSubstr("writeFileUnsynced(): cannot create"));
}

TEST(FileIoTest, JsonErrorsNameFileAndField) {
  test::TempDir dir;
  test::writeText(dir / "bad.json", "{\"a\": [1, 2");
  EXPECT_THAT([&] { readJsonFile(dir / "bad.json"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("bad.json: malformed JSON")));
  nlohmann::json obj = {{"x", "str"}};
  EXPECT_THAT([&] { requireField<int>(obj, "x", "ep 3"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("ep 3: field 'x' has the wrong type")));
  EXPECT_THAT([&] { requireField<int>(obj, "y", "ep 3"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("ep 3: field 'y' is missing")));
}

}  // namespace
}  // namespace vln::common
