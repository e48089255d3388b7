// The frozen default world (tests/data_files/world/README.md): generating
// configs/world/default.yaml again must give byte-identical evaluation files
// (val_seen, val_unseen, test) and held-out houses' scenes (.glb,
// .glb.navmesh, .glb.semantics.json of the 12 val_unseen and test houses),
// checked against tests/data_files/world/default_v1.sha256 with the SHA-256
// of support/Sha256.h (no sha256sum needed), and so must the test split's
// hidden goals and ground truth (default_v1_hidden.sha256). One generation of
// the 40 houses through bin/vlnce-data took 8.8 s of wall time on the 2-core
// machine with a load average of 6 (issue 16), so the test is in the default
// set.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "common/Json.h"
#include "data/Split.h"
#include "support/Sha256.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::reliability {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------
// SHA-256 itself: FIPS 180-2's examples (Appendix B) and the empty string

TEST(Sha256Test, KnownAnswers) {
  EXPECT_EQ(vln::test::sha256Hex(""),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(vln::test::sha256Hex("abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(vln::test::sha256Hex(
                "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ(vln::test::sha256Hex(std::string(1000000, 'a')),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Sha256Test, FileEqualsBytesAndNamesAMissingFile) {
  vln::test::TempDir dir;
  // 200 000 bytes cross the 64 KiB read buffer and many blocks
  std::string bytes;
  for (int i = 0; i < 200000; ++i) bytes += static_cast<char>(i * 7 % 251);
  const fs::path file = vln::test::writeText(dir / "bytes.bin", bytes);
  EXPECT_EQ(vln::test::sha256File(file), vln::test::sha256Hex(bytes));
  EXPECT_THAT(
      vln::test::errorOf([&] { vln::test::sha256File(dir / "missing.bin"); }),
      ::testing::HasSubstr("missing.bin"));
}

// ---------------------------------------------------------------------------
// the default world

// "<hash>  <path>" lines of a sha256sum list, by path
std::map<std::string, std::string> readHashList(const fs::path& file) {
  std::map<std::string, std::string> hashes;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    const size_t gap = line.find("  ");
    if (gap != 64) ADD_FAILURE() << file << ": malformed line '" << line << "'";
    if (gap == std::string::npos) continue;
    hashes[line.substr(gap + 2)] = line.substr(0, gap);
  }
  return hashes;
}

// the files the freeze covers: the evaluation splits and the scenes
bool frozen(const std::string& path) {
  for (const char* prefix : {"val_seen/", "val_unseen/", "test/", "scenes/"})
    if (path.starts_with(prefix)) return true;
  return false;
}

TEST(FrozenWorldTest, DefaultWorldEvaluationFilesMatchVersion1) {
  if (!fs::exists(vln::test::binary("vlnce-data")))
    GTEST_SKIP() << "build the vlnce-data binary first";
  const auto hashes =
      readHashList(vln::test::testDataPath() / "world" / "default_v1.sha256");

  // the world as README's check generates it
  vln::test::TempDir dir;
  const fs::path out = dir / "world";
  const std::string command =
      vln::test::binary("vlnce-data") + " generate --config " +
      (vln::test::sourcePath() / "configs/world/default.yaml").string() +
      " --out " + out.string() + " --scenes-dir " + (out / "scenes").string() +
      " --threads 2";
  std::string output;
  const auto start = std::chrono::steady_clock::now();
  ASSERT_EQ(vln::test::runCommand(command, &output), 0) << output;
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  RecordProperty("generation_seconds", std::to_string(seconds));
  std::cout << "default world generated in " << seconds << " s\n";

  // every frozen file byte-identical
  int checked = 0;
  for (const auto& [path, hash] : hashes) {
    if (!frozen(path)) continue;
    ++checked;
    const fs::path file = out / path;
    if (!fs::exists(file)) {
      ADD_FAILURE() << path << ": not generated any more";
      continue;
    }
    EXPECT_EQ(vln::test::sha256File(file), hash)
        << path << " changed: the default world's evaluation files are "
        << "frozen (tests/data_files/world/README.md); put the change in a "
        << "new world version";
  }
  // 5 split files (test has no public ground truth) + 12 houses x 3 files
  EXPECT_EQ(checked, 5 + 12 * 3);

  // the list covers every held-out house the generator reports
  const nlohmann::json stats =
      common::readJsonFile(out / "generation_stats.json");
  int heldOut = 0;
  for (const char* role : {"val_unseen", "test"}) {
    for (const auto& house : stats.at("house_roles").at(role)) {
      ++heldOut;
      const std::string name = house.get<std::string>();
      const std::string base = "scenes/procedural/" + name + "/" + name;
      for (const char* suffix : {".glb", ".glb.navmesh", ".glb.semantics.json"})
        EXPECT_TRUE(hashes.contains(base + suffix))
            << role << " house " << name << ": " << base << suffix
            << " is not in default_v1.sha256";
    }
  }
  EXPECT_EQ(heldOut, 12);

  // the test split's hidden goals and ground truth: frozen too, and they
  // cover every test episode
  int hidden = 0;
  for (const auto& [path, hash] : readHashList(
           vln::test::testDataPath() / "world" / "default_v1_hidden.sha256")) {
    ++hidden;
    EXPECT_EQ(vln::test::sha256File(out / path), hash) << path << " changed";
  }
  EXPECT_EQ(hidden, 2);
  data::Split test = data::loadSplit(out, "test", /*cap=*/-1);
  EXPECT_FALSE(test.hasGoals);
  data::attachHiddenGoals(test, data::findHiddenFiles(out, "test"));
  EXPECT_EQ(test.episodes.size(), 270u);
  EXPECT_EQ(test.groundTruth->size(), 270u);
}

}  // namespace
}  // namespace vln::reliability
