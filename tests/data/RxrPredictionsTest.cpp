// Tests src/data/RxrPredictions.cpp: the RxR inference output as VLN-CE
// writes it (.jsonl, one line per instruction_id, sorted, consecutive equal
// positions once), its strict reader, the merge of per-language files and
// the `vlnce-data rxr-merge` command (DataCommands.cpp).

#include "data/RxrPredictions.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sstream>

#include "common/FileIo.h"
#include "data/DataCommands.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::data {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using vln::test::errorOf;

RxrPrediction prediction(int64_t id, float x = 0.0f) {
  return {id, {{x, 0.5f, -1.0f}, {x + 0.25f, 0.5f, -1.0f}}};
}

std::vector<int64_t> ids(const std::vector<RxrPrediction>& predictions) {
  std::vector<int64_t> out;
  for (const RxrPrediction& p : predictions) out.push_back(p.instruction_id);
  return out;
}

TEST(RxrPredictionsTest, PathKeepsOnlyPositionsThatChanged) {
  const Vec3f a(0.0f, 0.1f, 0.0f), b(0.0f, 0.1f, -0.25f);
  EXPECT_THAT(rxrPathFromPositions({a, a, b, b, b, a}), ElementsAre(a, b, a));
  EXPECT_TRUE(rxrPathFromPositions({}).empty());
}

TEST(RxrPredictionsTest, WritesSortedLinesAndReadsThemBack) {
  vln::test::TempDir dir;
  const std::vector<RxrPrediction> predictions = {prediction(12, 1.0f),
                                                  prediction(3)};
  writeRxrPredictions(dir / "en.jsonl", predictions);
  EXPECT_EQ(vln::test::readText(dir / "en.jsonl"),
            "{\"instruction_id\":3,\"path\":[[0.0,0.5,-1.0],[0.25,0.5,-1.0]]}\n"
            "{\"instruction_id\":12,\"path\":[[1.0,0.5,-1.0],[1.25,0.5,-1.0]]"
            "}\n");
  EXPECT_THAT(readRxrPredictions(dir / "en.jsonl"),
              ElementsAre(predictions[1], predictions[0]));
  // what VLN-CE's jsonlines writer produces (spaces) reads the same
  EXPECT_THAT(parseRxrPredictions(
                  "{\"instruction_id\": 3, \"path\": [[0.0, 0.5, -1.0], "
                  "[0.25, 0.5, -1.0]]}\n",
                  "vlnce.jsonl"),
              ElementsAre(predictions[1]));
}

TEST(RxrPredictionsTest, RefusesBadPredictionsBeforeWriting) {
  vln::test::TempDir dir;
  EXPECT_THAT(
      errorOf([&] {
        writeRxrPredictions(dir / "x.jsonl", {prediction(3), prediction(3)});
      }),
      HasSubstr("instruction_id 3 appears twice"));
  EXPECT_THAT(errorOf([&] {
                writeRxrPredictions(dir / "x.jsonl", {{4, {}}});
              }),
              HasSubstr("instruction 4 has an empty path"));
  EXPECT_FALSE(fs::exists(dir / "x.jsonl"));
}

TEST(RxrPredictionsTest, RefusesMalformedLinesNamingFileAndLine) {
  const std::string good = "{\"instruction_id\": 1, \"path\": [[0, 0, 0]]}\n";
  const auto fails = [&](const std::string& second) {
    return errorOf([&] { parseRxrPredictions(good + second, "hi.jsonl"); });
  };
  EXPECT_THAT(fails("{\"instruction_id\": 2, \"path\": [[0, 0"),
              AllOf(HasSubstr("'hi.jsonl': line 2"), HasSubstr("malformed")));
  EXPECT_THAT(fails("\n" + good),
              AllOf(HasSubstr("line 2"), HasSubstr("blank line")));
  EXPECT_THAT(fails(good), AllOf(HasSubstr("line 2"),
                                 HasSubstr("already appears on line 1")));
  EXPECT_THAT(fails("{\"instruction_id\": \"2\", \"path\": [[0, 0, 0]]}"),
              HasSubstr("'instruction_id' must be an integer"));
  EXPECT_THAT(fails("{\"instruction_id\": 2}"),
              HasSubstr("field 'path' is missing"));
  EXPECT_THAT(fails("{\"instruction_id\": 2, \"path\": [[0, 0]]}"),
              HasSubstr("field 'path' entry 0"));
  EXPECT_THAT(fails("{\"instruction_id\": 2, \"path\": [], \"x\": 1}"),
              HasSubstr("unexpected key 'x'"));
  EXPECT_THAT(fails("[1, 2]"), HasSubstr("expected a JSON object"));
  EXPECT_THAT(fails("{\"instruction_id\": -2, \"path\": [[0, 0, 0]]}"),
              HasSubstr("negative"));
  // a final newline is optional
  EXPECT_EQ(
      parseRxrPredictions("{\"instruction_id\": 1, \"path\": [[0, 0, 0]]}", "x")
          .size(),
      1u);
}

TEST(RxrPredictionsTest, MergesLanguagesSortedAndRefusesDuplicates) {
  vln::test::TempDir dir;
  writeRxrPredictions(dir / "en.jsonl", {prediction(5), prediction(1)});
  writeRxrPredictions(dir / "hi.jsonl", {prediction(3), prediction(9)});
  writeRxrPredictions(dir / "te.jsonl", {prediction(2)});
  EXPECT_THAT(ids(mergeRxrPredictions(
                  {dir / "en.jsonl", dir / "hi.jsonl", dir / "te.jsonl"})),
              ElementsAre(1, 2, 3, 5, 9));

  writeRxrPredictions(dir / "dup.jsonl", {prediction(4), prediction(9)});
  EXPECT_THAT(errorOf([&] {
                mergeRxrPredictions({dir / "hi.jsonl", dir / "dup.jsonl"});
              }),
              AllOf(HasSubstr("dup.jsonl': line 2"),
                    HasSubstr("instruction_id 9 already appears in"),
                    HasSubstr("hi.jsonl': line 2")));
}

TEST(RxrPredictionsTest, MergeCommandWritesOneFile) {
  vln::test::TempDir dir;
  writeRxrPredictions(dir / "en.jsonl", {prediction(5)});
  writeRxrPredictions(dir / "hi.jsonl", {prediction(3)});
  std::ostringstream out;
  EXPECT_EQ(runRxrMergeCommand({.inputs = {dir / "en.jsonl", dir / "hi.jsonl"},
                                .out = dir / "merged.jsonl"},
                               out),
            0);
  EXPECT_THAT(out.str(), HasSubstr("2 instructions"));
  EXPECT_THAT(ids(readRxrPredictions(dir / "merged.jsonl")), ElementsAre(3, 5));

  // the binary, when built
  const std::string binary = vln::test::binary("vlnce-data");
  if (!fs::exists(binary)) return;
  std::string output;
  EXPECT_EQ(vln::test::runCommand(binary + " rxr-merge " +
                                      (dir / "en.jsonl").string() + " " +
                                      (dir / "en.jsonl").string() + " --out " +
                                      (dir / "bad.jsonl").string() + " 2>&1",
                                  &output) != 0,
            true);
  EXPECT_THAT(output, HasSubstr("already appears in"));
  EXPECT_FALSE(fs::exists(dir / "bad.jsonl"));
}

}  // namespace
}  // namespace vln::data
