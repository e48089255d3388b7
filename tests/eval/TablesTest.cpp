#include "eval/Tables.h"

#include <fstream>
#include <regex>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/FileIo.h"
#include "support/TestPaths.h"

namespace vln::eval {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

std::filesystem::path fixtureRuns() {
  return test::testDataPath() / "eval" / "results";
}

const TableRow& rowOf(const BuiltTable& table, const std::string& key) {
  for (const auto& row : table.rows)
    if (row.paper->key == key) return row;
  ADD_FAILURE() << "no row " << key;
  return table.rows.front();
}

int count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t pos = text.find(what); pos != std::string::npos;
       pos = text.find(what, pos + what.size()))
    ++n;
  return n;
}

// Copies the fixture results into a scratch directory that a test may edit.
void copyFixtures(const std::filesystem::path& to) {
  std::filesystem::copy(fixtureRuns(), to,
                        std::filesystem::copy_options::recursive);
}

TEST(TablesTest, OursComeFromTheChosenCheckpointsStatsFiles) {
  const auto tables = buildTables(fixtureRuns());
  ASSERT_EQ(tables.size(), 3u);

  const TableRow& seq = rowOf(tables[0], "Seq2Seq");
  ASSERT_TRUE(seq.ours.has_value());
  EXPECT_EQ(seq.ours->run, "seq2seq");
  EXPECT_EQ(seq.ours->checkpoint, 3);
  EXPECT_THAT(
      seq.ours->attributes,
      ::testing::ElementsAre("RGBD", std::string(kCheck), std::string(kCheck)));
  ASSERT_TRUE(seq.ours->values[0].has_value());
  // TL NE nDTW OS SR SPL of stats_ckpt_3_val_seen.json (not checkpoint 2's)
  EXPECT_THAT(*seq.ours->values[0],
              ::testing::ElementsAre(8.123, 8.457, 0.4449, 0.4, 0.2, 0.18765));
  EXPECT_EQ(seq.ours->num_episodes, (std::vector<int>{5, 7}));

  // the same run also fills Table 2 row 1
  EXPECT_EQ(rowOf(tables[1], "1").ours->run, "seq2seq");

  // Random has only val_unseen; Hand-Crafted has no run at all
  const TableRow& random = rowOf(tables[0], "Random");
  ASSERT_TRUE(random.ours.has_value());
  EXPECT_FALSE(random.ours->values[0].has_value());
  EXPECT_TRUE(random.ours->values[1].has_value());
  EXPECT_FALSE(rowOf(tables[0], "Hand-Crafted").ours.has_value());

  // Table 3 reads the nav-graph stats; only val_seen exists
  const TableRow& cross = rowOf(tables[2], "Cross-Modal");
  ASSERT_TRUE(cross.ours.has_value());
  EXPECT_THAT(*cross.ours->values[0],
              ::testing::ElementsAre(6.5432, 7.8123, 0.3333, 0.2666, 0.2222));
  EXPECT_FALSE(cross.ours->values[1].has_value());
  EXPECT_FALSE(cross.ours->values[2].has_value());
  EXPECT_THAT(
      rowOf(tables[1], "10").ours->attributes,
      ::testing::ElementsAre(std::string(kCheck), std::string(kCheckStar),
                             std::string(kCheck)));
}

TEST(TablesTest, MarkdownShowsPaperOursAndMissing) {
  const auto tables = buildTables(fixtureRuns());
  const std::string t1 = renderMarkdown(tables[0]);
  EXPECT_THAT(t1, HasSubstr("### Table 1: "));
  EXPECT_THAT(t1, HasSubstr("| Seq2Seq | RGBD | ✓ | ✓ | paper | 8.40 | 8.54 | "
                            "0.45 | 0.35 | 0.25 | 0.24 | 7.67 | 8.94 | 0.43 | "
                            "0.25 | 0.20 | 0.18 |"));
  EXPECT_THAT(t1,
              HasSubstr("| *ours: Seq2Seq* | RGBD | ✓ | ✓ | `seq2seq` [2] | "
                        "8.12 | 8.46 | 0.44 | 0.40 | 0.20 | 0.19 | 7.33 | "
                        "9.01 | 0.41 | 0.29 | 0.14 | 0.13 |"));
  // Random: val_seen missing, val_unseen from its file
  EXPECT_THAT(t1,
              HasSubstr("| `random` [1] | missing | missing | missing | "
                        "missing | missing | missing | 3.70 | 9.88 | 0.30 | "
                        "0.04 | 0.03 | 0.02 |"));
  // five Table 1 rows have no run: 12 missing metric cells each
  EXPECT_EQ(count(t1, "missing (no run)"), 5);
  EXPECT_EQ(count(t1, " missing |"), 5 * 12 + 6);
  // each of our rows cites its config and command
  EXPECT_THAT(
      t1, HasSubstr("[2] run seq2seq, checkpoint 3, episodes val_seen 5, "
                    "val_unseen 7; config `configs/seq2seq.yaml`; "
                    "command `build/bin/train --config "
                    "configs/seq2seq.yaml --set trainer.run_name=seq2seq`"));
  EXPECT_THAT(t1, HasSubstr("[1] run random, checkpoint 0, episodes val_seen "
                            "missing, val_unseen 9"));

  const std::string t2 = renderMarkdown(tables[1]);
  EXPECT_THAT(t2, HasSubstr("| # | Model | PM | DA | Aug. | Source |"));
  EXPECT_THAT(t2,
              HasSubstr("| 10 | Cross-Modal Attention | ✓ | ✓* | ✓ | paper | "
                        "9.26 | 7.12 | 0.54 | 0.46 | 0.37 | 0.35 |"));
  EXPECT_THAT(t2,
              HasSubstr("| 10 | *ours: Cross-Modal Attention* | ✓ | ✓* | ✓ |"));
  // the command's && stays inside the code span; nothing breaks the table
  EXPECT_THAT(t2, HasSubstr("&& build/bin/eval"));

  const std::string t3 = renderMarkdown(tables[2]);
  EXPECT_THAT(t3,
              HasSubstr("| RCM | ✓ | paper | 10.65 | 3.53 | 0.75 | 0.66 | - | "
                        "11.46 | 6.09 | 0.50 | 0.42 | - | 11.97 | 6.12 | "
                        "0.495 | 0.43 | 0.38 |"));
  EXPECT_THAT(t3, HasSubstr("6.54 | 7.81 | 0.33 | 0.27 | 0.22 | missing |"));
}

TEST(TablesTest, LatexEscapesAndMarksColumns) {
  const auto tables = buildTables(fixtureRuns());
  const std::string t2 = renderLatex(tables[1]);
  EXPECT_THAT(t2, HasSubstr("\\multicolumn{6}{c}{Val-Seen}"));
  EXPECT_THAT(t2, HasSubstr("\\cmidrule(lr){7-12}\\cmidrule(lr){13-18}"));
  EXPECT_THAT(t2, HasSubstr("10 & Cross-Modal Attention & \\checkmark & "
                            "\\checkmark$^*$ & \\checkmark & paper & 9.26"));
  EXPECT_THAT(t2, HasSubstr("run cma\\_all, checkpoint 11"));
  EXPECT_THAT(t2, HasSubstr("\\&\\& build/bin/eval"));
  EXPECT_THAT(t2, HasSubstr("\\begin{tabular}{rlcccl"));
  const std::string t3 = renderLatex(tables[2]);
  EXPECT_THAT(t3, HasSubstr("\\multicolumn{5}{c}{Test}"));
  EXPECT_THAT(t3, Not(HasSubstr("nDTW")));
}

TEST(TablesTest, WriteTablesWritesBothFormats) {
  test::TempDir dir;
  const auto [md, tex] = writeTables(buildTables(fixtureRuns()), dir.path());
  const std::string markdown = common::readFile(md);
  const std::string latex = common::readFile(tex);
  EXPECT_EQ(count(markdown, "### Table "), 3);
  EXPECT_EQ(count(latex, "\\begin{table}"), 3);
  EXPECT_EQ(count(latex, "\\begin{table}"), count(latex, "\\end{table}"));
}

TEST(TablesTest, BadRunFilesAreErrorsNamingFileAndField) {
  auto expectError = [](const std::string& runJson, const std::string& what) {
    test::TempDir dir;
    test::writeText(dir / "r" / "run.json", runJson);
    EXPECT_THAT([&] { buildTables(dir.path()); },
                ::testing::ThrowsMessage<std::invalid_argument>(
                    ::testing::AllOf(HasSubstr("run.json"), HasSubstr(what))))
        << runJson;
  };
  const std::string common =
      R"("model": "m", "checkpoint": 1, "config": "c.yaml", "command": "x")";
  expectError("{" + common + R"(, "rows": [{"table": 2, "row": "13"}]})",
              "table 2 has no row '13'");
  expectError("{" + common + R"(, "rows": [{"table": 4, "row": "1"}]})",
              "'table' must be 1, 2 or 3");
  expectError("{" + common + R"(, "rows": [{"table": 1, "row": "Seq2Seq"}]})",
              "field 'vision' is missing (Table 1 rows need it)");
  expectError("{" + common + R"(, "rows": [{"table": 2, "row": "3"}],
              "pm": true, "da": "yes", "aug": false})",
              "field 'da' must be one of none, dagger, dagger_finetune");
  expectError("{" + common +
                  R"(, "rows": [{"table": 3, "row": "RCM"}], "visoin": "D"})",
              "unknown field 'visoin'");
  expectError(R"({"model": "m", "rows": [{"table": 3, "row": "RCM"}]})",
              "field 'checkpoint' is missing");
  expectError("{" + common + R"(, "rows": [{"table": 3, "row": "RCM"}]})",
              "row 'RCM' is another paper's nav-graph model");

  // a malformed stats file is named too
  test::TempDir dir;
  test::writeText(
      dir / "r" / "run.json",
      "{" + common + R"(, "rows": [{"table": 3, "row": "Cross-Modal"}]})");
  test::writeText(dir / "r" / "navgraph_stats_ckpt_1_test.json",
                  R"({"spl": 1})");
  EXPECT_THAT([&] { buildTables(dir.path()); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("navgraph_stats_ckpt_1_test.json")));

  EXPECT_THAT([&] { buildTables(dir / "nope"); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("nope")));
}

TEST(TablesTest, TwoRunsCannotClaimOneRow) {
  test::TempDir dir;
  copyFixtures(dir / "results");
  test::writeText(
      dir / "results" / "zz_other" / "run.json",
      R"({"model": "m", "checkpoint": 1, "config": "c", "command": "x",
                      "rows": [{"table": 2, "row": "10"}],
                      "pm": true, "da": "dagger", "aug": true})");
  EXPECT_THAT([&] { buildTables(dir / "results"); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::AllOf(
                  HasSubstr("table 2 row '10' is claimed by both"),
                  HasSubstr("cma_all"), HasSubstr("zz_other"))));
}

TEST(TablesTest, EmptyResultsGiveOnlyPaperRowsAndMissing) {
  test::TempDir dir;
  const auto tables = buildTables(dir.path());
  for (const auto& table : tables)
    for (const auto& row : table.rows) EXPECT_FALSE(row.ours.has_value());
  // Table 3: other papers' nav-graph models get no "ours" line
  const std::string md = renderMarkdown(tables[2]);
  EXPECT_EQ(count(md, "missing (no run)"), 1);
  EXPECT_EQ(count(md, "*ours"), 1);
  EXPECT_THAT(md, Not(HasSubstr("[1]")));
}

// The transcription in PaperResults.cpp against the paper's LaTeX: every
// number of every row line of Tables 1-3, in order.
TEST(TablesTest, PaperNumbersMatchTheLatexSource) {
  const auto texFile = test::sharedFixturesPath().parent_path() / "reference" /
                       "vlnce_paper.tex";
  if (!std::filesystem::exists(texFile)) GTEST_SKIP() << texFile << " absent";
  const std::string tex = common::readFile(texFile);
  const std::vector<std::pair<int, std::string>> labels{
      {1, "\\label{tab:ablate}"},
      {2, "\\label{tab:results}"},
      {3, "\\label{tab:test}"}};
  // numbers of cells, not lengths such as [-0.5em]
  const std::regex number(R"((^|[^\w.])(\d+\.\d+)(?!\d|em|pt))");
  for (const auto& [n, label] : labels) {
    const size_t at = tex.find(label);
    ASSERT_NE(at, std::string::npos) << label;
    const size_t end = tex.find("\\end{table}", at);
    std::istringstream block(tex.substr(at, end - at));
    std::vector<std::string> fromTex;
    for (std::string line; std::getline(block, line);) {
      if (line.find('&') == std::string::npos) continue;  // rules, spacing
      for (std::sregex_iterator it(line.begin(), line.end(), number), stop;
           it != stop; ++it)
        fromTex.push_back((*it)[2]);
    }
    std::vector<std::string> ours;
    for (const auto& row : paperTable(n).rows)
      for (const auto& split : row.values)
        for (const auto& value : split)
          if (value != kNone) ours.push_back(value);
    EXPECT_EQ(ours, fromTex) << "table " << n;
    // and the "-" cells: the paper's Table 3 has 10 unreported values
    if (n == 3) {
      int dashes = 0;
      for (const auto& row : paperTable(3).rows)
        for (const auto& split : row.values)
          dashes += static_cast<int>(
              std::count(split.begin(), split.end(), std::string(kNone)));
      EXPECT_EQ(dashes, 10);
    }
  }
}

}  // namespace
}  // namespace vln::eval
