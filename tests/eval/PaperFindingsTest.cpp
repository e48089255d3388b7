#include "eval/PaperFindings.h"

#include <set>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/Check.h"
#include "support/TestPaths.h"

namespace vln::eval {
namespace {

using ::testing::HasSubstr;

std::vector<BuiltTable> seedTables() {
  return buildTables(test::testDataPath() / "eval" / "seeds");
}

const FindingJudgement& judgementOf(
    const std::vector<FindingJudgement>& judgements, const std::string& better,
    const std::string& worse) {
  for (const auto& j : judgements)
    if (j.finding->better.row == better && j.finding->worse.row == worse)
      return j;
  ADD_FAILURE() << "no finding " << better << " > " << worse;
  return judgements.front();
}

TEST(PaperFindingsTest, EveryFindingNamesTwoRowsOfOnePaperTable) {
  std::set<std::pair<std::string, std::string>> pairs;
  for (const auto& f : paperFindings()) {
    EXPECT_EQ(f.better.table, f.worse.table) << f.claim;
    EXPECT_NE(f.better.row, f.worse.row) << f.claim;
    for (const RowRef& ref : {f.better, f.worse}) {
      const PaperRow* row = paperTable(ref.table).findRow(ref.row);
      ASSERT_NE(row, nullptr) << ref.table << " " << ref.row;
      EXPECT_TRUE(row->reproducible) << ref.row;
    }
    EXPECT_FALSE(f.claim.empty());
    EXPECT_TRUE(pairs.emplace(f.better.row, f.worse.row).second)
        << "listed twice: " << f.better.row << " > " << f.worse.row;
  }
  // the findings docs/results.md discusses: DAgger, PM, no vision, CMA
  EXPECT_TRUE(pairs.contains({"3", "1"}));
  EXPECT_TRUE(pairs.contains({"8", "6"}));
  EXPECT_TRUE(pairs.contains({"1", "2"}));
  EXPECT_TRUE(pairs.contains({"Seq2Seq", "No Vision"}));
  EXPECT_TRUE(pairs.contains({"6", "1"}));
}

// The fixture seeds (tests/data_files/eval/seeds), val_unseen:
//   Seq2Seq (row 1)  SR 0.10 0.20 0.30   SPL 0.10 0.15 0.20   NE 8 7 6
//   CMA (row 6)      SR 0.20 0.31 0.40   SPL 0.05 0.11 0.14   NE 8 8 8
//   Seq2Seq DA (3)   SR 0.15 0.18        SPL 0.15 0.18        (seeds 0, 1)
//   Random           SR 0.03             (seed 0)
TEST(PaperFindingsTest, PairedDifferencesByHand) {
  const auto judgements =
      judgeFindings(seedTables(), paperFindings(), "val_unseen", {"SR", "SPL"});
  ASSERT_EQ(judgements.size(), paperFindings().size());

  // CMA beats Seq2Seq: SR by +0.10, +0.11, +0.10 (mean 0.103333, s
  // 0.0057735, half-width 4.302653 s / sqrt(3) = 0.014342): holds; SPL by
  // -0.05, -0.04, -0.06 (half-width 4.302653 0.01 / sqrt(3) = 0.024842):
  // does not hold
  const FindingJudgement& cma = judgementOf(judgements, "6", "1");
  EXPECT_EQ(cma.better_label, "T2 #6 Cross-Modal Attention");
  EXPECT_EQ(cma.worse_label, "T2 #1 Seq2Seq");
  EXPECT_EQ(cma.seeds, (std::vector<int>{0, 1, 2}));
  ASSERT_EQ(cma.metrics.size(), 2u);
  EXPECT_EQ(cma.metrics[0].metric, "SR");
  EXPECT_NEAR(cma.metrics[0].improvement->mean, 0.103333, 1e-6);
  EXPECT_NEAR(cma.metrics[0].improvement->half_width, 0.014342, 1e-6);
  EXPECT_EQ(cma.metrics[0].verdict, Verdict::kHolds);
  EXPECT_NEAR(*cma.metrics[0].paper_improvement, 0.23 - 0.20, 1e-12);
  EXPECT_NEAR(cma.metrics[1].improvement->mean, -0.05, 1e-12);
  EXPECT_NEAR(cma.metrics[1].improvement->half_width, 0.024842, 1e-6);
  EXPECT_EQ(cma.metrics[1].verdict, Verdict::kDoesNotHold);

  // DAgger on two seeds: SR +0.05, -0.02, mean 0.015, half-width
  // t_{0.975,1} 0.049497 / sqrt(2) = 12.706205 * 0.035 = 0.444717
  const FindingJudgement& dagger = judgementOf(judgements, "3", "1");
  EXPECT_EQ(dagger.better_label, "T2 #3 Seq2Seq DA");
  EXPECT_EQ(dagger.seeds, (std::vector<int>{0, 1}));
  EXPECT_NEAR(dagger.metrics[0].improvement->mean, 0.015, 1e-12);
  EXPECT_NEAR(dagger.metrics[0].improvement->half_width, 0.444717, 1e-6);
  EXPECT_EQ(dagger.metrics[0].verdict, Verdict::kCannotTell);

  // one shared seed says nothing; no shared seed gives no number
  const FindingJudgement& random = judgementOf(judgements, "Seq2Seq", "Random");
  EXPECT_EQ(random.better_label, "T1 Seq2Seq");
  EXPECT_EQ(random.seeds, (std::vector<int>{0}));
  EXPECT_NEAR(random.metrics[0].improvement->mean, 0.10 - 0.03, 1e-12);
  EXPECT_EQ(random.metrics[0].verdict, Verdict::kCannotTell);
  const FindingJudgement& hand =
      judgementOf(judgements, "Seq2Seq", "Hand-Crafted");
  EXPECT_TRUE(hand.seeds.empty());
  EXPECT_FALSE(hand.metrics[0].improvement.has_value());
  EXPECT_EQ(hand.metrics[0].verdict, Verdict::kCannotTell);
  EXPECT_NEAR(*hand.metrics[0].paper_improvement, 0.20 - 0.03, 1e-12);

  const auto counts = countVerdicts(judgements);
  EXPECT_EQ(counts.at(Verdict::kHolds), 1);
  EXPECT_EQ(counts.at(Verdict::kDoesNotHold), 1);
  EXPECT_EQ(counts.at(Verdict::kCannotTell),
            2 * static_cast<int>(judgements.size()) - 2);
}

// Where lower is better the improvement is (worse - better): CMA's NE 8
// against Seq2Seq's 8, 7, 6 is an improvement of 0, -1, -2; the paper's
// 8.14 against 8.94 one of +0.80.
TEST(PaperFindingsTest, LowerIsBetterMetricsAreNegated) {
  const auto judgements =
      judgeFindings(seedTables(), paperFindings(), "val_unseen", {"NE"});
  const FindingJudgement& cma = judgementOf(judgements, "6", "1");
  EXPECT_NEAR(cma.metrics[0].improvement->mean, -1.0, 1e-12);
  EXPECT_NEAR(*cma.metrics[0].paper_improvement, 0.80, 1e-12);
}

TEST(PaperFindingsTest, FindingsTheTablesLackAreErrors) {
  const auto tables = seedTables();
  auto expectError = [&](const std::vector<PaperFinding>& findings,
                         std::string_view split,
                         const std::vector<std::string>& metrics,
                         const std::string& what) {
    EXPECT_THAT([&] { judgeFindings(tables, findings, split, metrics); },
                ::testing::ThrowsMessage<std::invalid_argument>(
                    ::testing::AllOf(HasSubstr("finding 1"), HasSubstr(what))));
  };
  const PaperFinding ok{{2, "6"}, {2, "1"}, "claim"};
  expectError({{{2, "13"}, {2, "1"}, "x"}}, "val_unseen", {"SR"},
              "table 2 row '13'");
  expectError({{{1, "Seq2Seq"}, {2, "1"}, "x"}}, "val_unseen", {"SR"},
              "rows of different tables");
  expectError({ok}, "test", {"SR"}, "split 'test'");
  expectError({ok}, "val_unseen", {"XYZ"}, "metric 'XYZ'");
}

TEST(PaperFindingsTest, MarkdownListsFindingsAndVerdicts) {
  const auto judgements =
      judgeFindings(seedTables(), paperFindings(), "val_unseen", {"SR", "SPL"});
  const std::string md = renderFindingsMarkdown(judgements, "val_unseen");
  EXPECT_THAT(md, HasSubstr("### Paired differences: the paper's findings on "
                            "val_unseen"));
  EXPECT_THAT(md, HasSubstr("95% Student t interval"));
  EXPECT_THAT(md, HasSubstr("| # | Paper's finding | Better (paper) | Worse "
                            "(paper) | n | SR ours | SR paper | SR verdict | "
                            "SPL ours | SPL paper | SPL verdict |"));
  EXPECT_THAT(md, HasSubstr("| T2 #6 Cross-Modal Attention | T2 #1 Seq2Seq | "
                            "3 | +0.103 ± 0.014 | +0.03 | holds | "
                            "-0.050 ± 0.025 | +0.04 | does not hold |"));
  EXPECT_THAT(md, HasSubstr("| T1 Seq2Seq | T1 Random | 1 | +0.070 | +0.17 | "
                            "cannot tell |"));
  EXPECT_THAT(md, HasSubstr("| T1 Seq2Seq | T1 Hand-Crafted | 0 | - | +0.17 | "
                            "cannot tell |"));
  EXPECT_THAT(md, HasSubstr("We find DAgger-based training impactful"));
  EXPECT_THAT(md, HasSubstr("T2 #10 Cross-Modal Attention PM+DA*+Aug"));
  const size_t all = 2 * judgements.size();
  EXPECT_THAT(md, HasSubstr(strCat("Verdicts on val_unseen (", all,
                                   " in all): 1 hold, 1 do not hold, ", all - 2,
                                   " cannot tell.")));
}

}  // namespace
}  // namespace vln::eval
