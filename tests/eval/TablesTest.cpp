#include "eval/Tables.h"

#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/FileIo.h"
#include "common/Json.h"
#include "support/TestPaths.h"

namespace vln::eval {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

std::filesystem::path fixtureRuns() {
  return test::testDataPath() / "eval" / "results";
}

// Runs of several seeds, <experiment>/seed<S>/ (values chosen so the
// intervals below can be computed by hand; see each test).
std::filesystem::path fixtureSeeds() {
  return test::testDataPath() / "eval" / "seeds";
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

// Copies fixture results into a scratch directory that a test may edit.
void copyFixtures(const std::filesystem::path& to,
                  const std::filesystem::path& from = fixtureRuns()) {
  std::filesystem::copy(from, to, std::filesystem::copy_options::recursive);
}

TEST(TablesTest, OursComeFromTheChosenCheckpointsStatsFiles) {
  const auto tables = buildTables(fixtureRuns());
  ASSERT_EQ(tables.size(), 3u);

  const TableRow& seq = rowOf(tables[0], "Seq2Seq");
  ASSERT_TRUE(seq.ours.has_value());
  ASSERT_EQ(seq.ours->seeds.size(), 1u);
  const SeedRun& run = seq.ours->seeds[0];
  EXPECT_EQ(run.run, "seq2seq");
  EXPECT_EQ(run.seed, 0);  // run.json has no seed: trainer.seed's default
  EXPECT_EQ(run.checkpoint, 3);
  EXPECT_THAT(
      seq.ours->attributes,
      ::testing::ElementsAre("RGBD", std::string(kCheck), std::string(kCheck)));
  ASSERT_TRUE(run.splits[0].has_value());
  // TL NE nDTW OS SR SPL of stats_ckpt_3_val_seen.json (not checkpoint 2's);
  // the file predates ONE and OSPL
  EXPECT_THAT(run.splits[0]->metrics,
              ::testing::ElementsAre(8.123, 8.457, 0.4449, 0.4, 0.2, 0.18765,
                                     std::nullopt, std::nullopt));
  EXPECT_EQ(run.splits[0]->num_episodes, 5);
  EXPECT_EQ(run.splits[1]->num_episodes, 7);
  // one seed: the cells are its values
  EXPECT_EQ(seq.ours->cells[0][1]->mean, 8.457);
  EXPECT_EQ(seq.ours->cells[0][1]->n, 1);
  EXPECT_FALSE(seq.ours->cells[0][6].has_value());

  // the same run also fills Table 2 row 1
  EXPECT_EQ(rowOf(tables[1], "1").ours->seeds[0].run, "seq2seq");

  // Random has only val_unseen; Hand-Crafted has no run at all
  const TableRow& random = rowOf(tables[0], "Random");
  ASSERT_TRUE(random.ours.has_value());
  EXPECT_FALSE(random.ours->seeds[0].splits[0].has_value());
  EXPECT_TRUE(random.ours->seeds[0].splits[1].has_value());
  EXPECT_EQ(random.ours->seeds_with_split, (std::vector<int>{0, 1}));
  EXPECT_FALSE(rowOf(tables[0], "Hand-Crafted").ours.has_value());

  // Table 3 reads the nav-graph stats; only val_seen exists
  const TableRow& cross = rowOf(tables[2], "Cross-Modal");
  ASSERT_TRUE(cross.ours.has_value());
  const SeedRun& graph = cross.ours->seeds[0];
  EXPECT_THAT(graph.splits[0]->metrics,
              ::testing::ElementsAre(6.5432, 7.8123, 0.3333, 0.2666, 0.2222));
  EXPECT_FALSE(graph.splits[1].has_value());
  EXPECT_FALSE(graph.splits[2].has_value());
  EXPECT_THAT(
      rowOf(tables[1], "10").ours->attributes,
      ::testing::ElementsAre(std::string(kCheck), std::string(kCheckStar),
                             std::string(kCheck)));
}

TEST(TablesTest, MarkdownShowsPaperOursAndMissing) {
  const auto tables = buildTables(fixtureRuns());
  const std::string t1 = renderMarkdown(tables[0]);
  EXPECT_THAT(t1, HasSubstr("### Table 1: "));
  // the paper reports neither ONE nor OSPL
  EXPECT_THAT(t1, HasSubstr("| Seq2Seq | RGBD | ✓ | ✓ | paper | - | 8.40 | "
                            "8.54 | 0.45 | 0.35 | 0.25 | 0.24 | - | - | 7.67 | "
                            "8.94 | 0.43 | 0.25 | 0.20 | 0.18 | - | - |"));
  // one seed: values without an interval, n = 1; "-" where the stats file
  // predates ONE and OSPL
  EXPECT_THAT(t1,
              HasSubstr("| *ours: Seq2Seq* | RGBD | ✓ | ✓ | `seq2seq` [2] | "
                        "1 | 8.12 | 8.46 | 0.44 | 0.40 | 0.20 | 0.19 | - | - | "
                        "7.33 | 9.01 | 0.41 | 0.29 | 0.14 | 0.13 | - | - |"));
  // Random: val_seen missing, val_unseen from its file
  EXPECT_THAT(t1, HasSubstr("| `random` [1] | 1 (val_seen 0) | missing | "
                            "missing | missing | missing | missing | missing | "
                            "missing | missing | 3.70 | 9.88 | 0.30 | 0.04 | "
                            "0.03 | 0.02 | - | - |"));
  // five Table 1 rows have no run: 16 missing metric cells each
  EXPECT_EQ(count(t1, "missing (no run) | 0 |"), 5);
  EXPECT_EQ(count(t1, " missing |"), 5 * 16 + 8);
  EXPECT_THAT(t1, HasSubstr("| Source | n | Val-Seen TL ↓ |"));
  EXPECT_THAT(t1, HasSubstr("| Val-Unseen ONE ↓ | Val-Unseen OSPL ↑ |"));
  // each of our rows cites its seed, checkpoint, config and command
  EXPECT_THAT(
      t1, HasSubstr("[2] run seq2seq (seed 0, checkpoint 3); episodes "
                    "val_seen 5, val_unseen 7; config `configs/seq2seq.yaml`; "
                    "command `build/bin/train --config "
                    "configs/seq2seq.yaml --set trainer.run_name=seq2seq`"));
  EXPECT_THAT(t1, HasSubstr("[1] run random (seed 0, checkpoint 0); episodes "
                            "val_seen missing, val_unseen 9"));

  const std::string t2 = renderMarkdown(tables[1]);
  EXPECT_THAT(t2, HasSubstr("| # | Model | PM | DA | Aug. | Source | n |"));
  EXPECT_THAT(
      t2, HasSubstr("| 10 | Cross-Modal Attention | ✓ | ✓* | ✓ | paper | - | "
                    "9.26 | 7.12 | 0.54 | 0.46 | 0.37 | 0.35 | - | - |"));
  EXPECT_THAT(t2,
              HasSubstr("| 10 | *ours: Cross-Modal Attention* | ✓ | ✓* | ✓ |"));
  // the command's && stays inside the code span; nothing breaks the table
  EXPECT_THAT(t2, HasSubstr("&& build/bin/eval"));

  // Table 3 has no added metrics
  const std::string t3 = renderMarkdown(tables[2]);
  EXPECT_THAT(t3,
              HasSubstr("| RCM | ✓ | paper | - | 10.65 | 3.53 | 0.75 | 0.66 | "
                        "- | 11.46 | 6.09 | 0.50 | 0.42 | - | 11.97 | 6.12 | "
                        "0.495 | 0.43 | 0.38 |"));
  EXPECT_THAT(t3, HasSubstr("6.54 | 7.81 | 0.33 | 0.27 | 0.22 | missing |"));
  EXPECT_THAT(t3, Not(HasSubstr("ONE")));
}

TEST(TablesTest, LatexEscapesAndMarksColumns) {
  const auto tables = buildTables(fixtureRuns());
  const std::string t2 = renderLatex(tables[1]);
  EXPECT_THAT(t2, HasSubstr("\\multicolumn{8}{c}{Val-Seen}"));
  // leading columns: #, model, PM, DA, Aug., source, n
  EXPECT_THAT(t2, HasSubstr("\\cmidrule(lr){8-15}\\cmidrule(lr){16-23}"));
  EXPECT_THAT(t2, HasSubstr("10 & Cross-Modal Attention & \\checkmark & "
                            "\\checkmark$^*$ & \\checkmark & paper & - & "
                            "9.26"));
  EXPECT_THAT(t2, HasSubstr("run cma\\_all (seed 0, checkpoint 11)"));
  EXPECT_THAT(t2, HasSubstr("\\&\\& build/bin/eval"));
  EXPECT_THAT(t2, HasSubstr("\\begin{tabular}{rlccclr"));
  EXPECT_THAT(t2, HasSubstr(" & Source & $n$ & TL"));
  const std::string t3 = renderLatex(tables[2]);
  EXPECT_THAT(t3, HasSubstr("\\multicolumn{5}{c}{Test}"));
  EXPECT_THAT(t3, Not(HasSubstr("nDTW")));
}

TEST(TablesTest, WriteTablesWritesBothFormats) {
  test::TempDir dir;
  const auto [md, tex] =
      writeTables(buildTables(fixtureRuns()), dir / "tables.md", "the test");
  EXPECT_EQ(md, dir / "tables.md");
  EXPECT_EQ(tex, dir / "tables.tex");
  const std::string markdown = common::readFile(md);
  const std::string latex = common::readFile(tex);
  EXPECT_THAT(markdown, HasSubstr("<!-- Generated by `the test`"));
  EXPECT_THAT(latex, HasSubstr("% Generated by `the test`"));
  EXPECT_EQ(count(markdown, "### Table "), 3);
  EXPECT_EQ(count(latex, "\\begin{table}"), 3);
  EXPECT_EQ(count(latex, "\\begin{table}"), count(latex, "\\end{table}"));

  // LaTeX never beside itself; no table at all says so
  EXPECT_THAT([&] { writeTables({}, dir / "t.tex", "x"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("must not end in .tex")));
  writeTables({}, dir / "none.md", "x");
  EXPECT_THAT(common::readFile(dir / "none.md"),
              HasSubstr("No run claims a row of the paper's tables."));
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

// Seq2Seq's three seeds: val_unseen NE 8, 7, 6, SR 0.1, 0.2, 0.3, SPL
// 0.10, 0.15, 0.20, ONE 4, 5, 6, OSPL 0.25 each; val_seen SR 0.2 each, and
// seed 2's val_seen file predates ONE and OSPL.
TEST(TablesTest, SeedsOfARowGiveMeanAndStudentInterval) {
  const auto tables = buildTables(fixtureSeeds());
  const TableRow& seq = rowOf(tables[0], "Seq2Seq");
  ASSERT_TRUE(seq.ours.has_value());
  ASSERT_EQ(seq.ours->seeds.size(), 3u);
  EXPECT_EQ(seq.ours->seeds[1].run, "seq2seq/seed1");
  EXPECT_EQ(seq.ours->seeds[1].seed, 1);
  EXPECT_EQ(seq.ours->seeds[1].checkpoint, 4);
  EXPECT_EQ(seq.ours->seeds_with_split, (std::vector<int>{3, 3}));
  const auto& unseen = seq.ours->cells[1];
  // SR: mean 0.2, s 0.1, half-width t_{0.975,2} 0.1 / sqrt(3) = 0.248414
  EXPECT_NEAR(unseen[4]->mean, 0.2, 1e-12);
  EXPECT_NEAR(unseen[4]->half_width, 0.248414, 1e-6);
  EXPECT_EQ(unseen[4]->n, 3);
  // NE and ONE: mean 7 and 5, s 1, half-width 4.302653 / sqrt(3) = 2.484138
  EXPECT_NEAR(unseen[1]->mean, 7.0, 1e-12);
  EXPECT_NEAR(unseen[1]->half_width, 2.484138, 1e-6);
  EXPECT_NEAR(unseen[6]->mean, 5.0, 1e-12);
  EXPECT_NEAR(unseen[6]->half_width, 2.484138, 1e-6);
  // OSPL is the same for every seed: no spread
  EXPECT_NEAR(unseen[7]->mean, 0.25, 1e-12);
  EXPECT_EQ(unseen[7]->half_width, 0.0);
  // one seed lacks val_seen's ONE and OSPL: no mean over the other two
  EXPECT_FALSE(seq.ours->cells[0][6].has_value());
  EXPECT_FALSE(seq.ours->cells[0][7].has_value());

  // CMA's seed 2 has no val_seen: val_seen rests on two seeds
  const TableRow& cma = rowOf(tables[1], "6");
  EXPECT_EQ(cma.ours->seeds_with_split, (std::vector<int>{2, 3}));
  EXPECT_EQ(cma.ours->cells[0][4]->n, 2);
}

TEST(TablesTest, MarkdownShowsIntervalsAndSeedCounts) {
  const auto tables = buildTables(fixtureSeeds());
  const std::string t1 = renderMarkdown(tables[0]);
  EXPECT_THAT(
      t1, HasSubstr("| *ours: Seq2Seq* | RGBD | ✓ | ✓ | `seq2seq` [2] | 3 | "
                    "7.00 ± 0.00 | 8.00 ± 0.00 | 0.40 ± 0.00 | "
                    "0.30 ± 0.00 | 0.20 ± 0.00 | 0.20 ± 0.00 | - | - | "
                    "7.00 ± 0.00 | 7.00 ± 2.48 | 0.40 ± 0.00 | "
                    "0.30 ± 0.00 | 0.20 ± 0.25 | 0.15 ± 0.12 | "
                    "5.00 ± 2.48 | 0.25 ± 0.00 |"));
  // one seed: the value alone
  EXPECT_THAT(t1, HasSubstr("| `random/seed0` [1] | 1 | 7.00 | 8.00 |"));
  EXPECT_THAT(
      t1, HasSubstr("[2] runs seq2seq/seed0 (seed 0, checkpoint 3), "
                    "seq2seq/seed1 (seed 1, checkpoint 4), seq2seq/seed2 "
                    "(seed 2, checkpoint 5); episodes val_seen 10, "
                    "val_unseen 10; config `configs/experiments/seq2seq.yaml`; "
                    "commands `build/bin/eval --config "
                    "configs/experiments/seq2seq.yaml --set trainer.seed=0 "
                    "--out results/paper/seq2seq/seed0`, `"));

  const std::string t2 = renderMarkdown(tables[1]);
  // CMA: a split fewer seeds have is named in n; no file has ONE or OSPL
  EXPECT_THAT(t2, HasSubstr("| `cma` [3] | 3 (val_seen 2) | 7.00 ± 0.00 |"));
  EXPECT_THAT(t2, HasSubstr("| 0.30 ± 0.00 | 0.25 ± 0.00 | - | - | "
                            "7.00 ± 0.00 |"));
  EXPECT_THAT(t2, HasSubstr("| `seq2seq_da` [2] | 2 |"));
}

TEST(TablesTest, LatexPrintsPlusMinusInMathMode) {
  const auto tables = buildTables(fixtureSeeds());
  const std::string t1 = renderLatex(tables[0]);
  EXPECT_THAT(t1, HasSubstr(" & [2] & 3 & 7.00 $\\pm$ 0.00 & "));
  EXPECT_THAT(t1, HasSubstr("0.20 $\\pm$ 0.25 & 0.15 $\\pm$ 0.12 & "
                            "5.00 $\\pm$ 2.48 & 0.25 $\\pm$ 0.00 \\\\"));
  EXPECT_THAT(t1, Not(HasSubstr("±")));
  EXPECT_THAT(t1, HasSubstr("runs seq2seq/seed0 (seed 0, checkpoint 3)"));
  EXPECT_THAT(renderLatex(tables[1]), HasSubstr(" & 3 (val\\_seen 2) & "));
}

TEST(TablesTest, ClaimedRowsOnlyKeepsWhatRunsClaim) {
  const auto tables = claimedRowsOnly(buildTables(fixtureSeeds()));
  // Table 3: nothing claimed, no table
  ASSERT_EQ(tables.size(), 2u);
  std::vector<std::string> keys;
  for (const auto& table : tables)
    for (const auto& row : table.rows) keys.push_back(row.paper->key);
  EXPECT_THAT(keys, ::testing::ElementsAre("Random", "Seq2Seq", "1", "3", "6"));
  const std::string t1 = renderMarkdown(tables[0]);
  EXPECT_THAT(t1, Not(HasSubstr("missing (no run)")));
  EXPECT_THAT(t1, Not(HasSubstr("Hand-Crafted")));
  // each claimed row still beside the paper's
  EXPECT_THAT(t1, HasSubstr("| Random | - | - | - | paper | - | 3.54 |"));
  EXPECT_EQ(tables[1].findRow("2"), nullptr);
  ASSERT_NE(tables[1].findRow("6"), nullptr);
  EXPECT_TRUE(claimedRowsOnly(buildTables(test::TempDir().path())).empty());
}

TEST(TablesTest, SeedsOfOneRowMustDifferAndAgree) {
  test::TempDir dir;
  copyFixtures(dir / "runs", fixtureSeeds());
  const auto seed1 = dir / "runs" / "seq2seq" / "seed1" / "run.json";
  std::string json = common::readFile(seed1);

  // two runs of one row with one seed
  test::writeText(seed1, std::regex_replace(json, std::regex(R"("seed": 1)"),
                                            R"("seed": 0)"));
  EXPECT_THAT(
      [&] { buildTables(dir / "runs"); },
      ::testing::ThrowsMessage<std::invalid_argument>(::testing::AllOf(
          HasSubstr("table 1 row 'Seq2Seq' is claimed by both"),
          HasSubstr("seed0"), HasSubstr("seed1"), HasSubstr("with seed 0"))));

  // seeds that disagree on what the row is
  test::writeText(seed1, std::regex_replace(json, std::regex(R"("pm": false)"),
                                            R"("pm": true)"));
  EXPECT_THAT([&] { buildTables(dir / "runs"); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::AllOf(
                  HasSubstr("table 2 row '1' disagree on the model or its "
                            "attributes"),
                  HasSubstr("seed1"))));

  test::writeText(seed1, std::regex_replace(json, std::regex(R"("seed": 1)"),
                                            R"("seed": -1)"));
  EXPECT_THAT([&] { buildTables(dir / "runs"); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::AllOf(
                  HasSubstr("seed1/run.json"),
                  HasSubstr("field 'seed' must be >= 0, got -1"))));
}

TEST(TablesTest, StatsFilesNeedThePapersMetricsOnly) {
  test::TempDir dir;
  copyFixtures(dir / "runs", fixtureSeeds());
  const auto file =
      dir / "runs" / "random" / "seed0" / "stats_ckpt_0_val_unseen.json";
  nlohmann::json stats = nlohmann::json::parse(common::readFile(file));

  // JSON has no infinity: a null mean is an unreachable goal's
  stats["distance_to_goal"] = nullptr;
  test::writeText(file, stats.dump());
  const auto tables = buildTables(dir / "runs");
  EXPECT_TRUE(std::isinf(rowOf(tables[0], "Random").ours->cells[1][1]->mean));
  EXPECT_THAT(renderMarkdown(tables[0]),
              HasSubstr("| `random/seed0` [1] | 1 | 7.00 | 8.00 | 0.40 | "
                        "0.30 | 0.02 | 0.02 | - | - | 7.00 | inf |"));

  // a metric of the paper's is required
  stats.erase("spl");
  test::writeText(file, stats.dump());
  EXPECT_THAT([&] { buildTables(dir / "runs"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  ::testing::AllOf(HasSubstr("stats_ckpt_0_val_unseen.json"),
                                   HasSubstr("field 'spl' is missing"))));
  stats["spl"] = "high";
  test::writeText(file, stats.dump());
  EXPECT_THAT([&] { buildTables(dir / "runs"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("field 'spl' must be a number")));
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
