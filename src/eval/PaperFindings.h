#pragma once
// The conclusions the paper draws from pairs of rows of its Tables 1 and 2
// (Krantz et al. 2020, Section 5), listed once in paperFindings(), and
// their verdicts on our runs. A finding says one row is better than
// another; it is judged per metric by the paired difference over training
// seeds: for every seed both rows have, (better row - other row), oriented
// so that positive is the paper's direction (negated for metrics where
// lower is better), then the mean over seeds and its 95% Student t
// interval (SeedStatistics.h). The interval decides: excludes 0 on the
// paper's side "holds", on the other side "does not hold", else "cannot
// tell". Pairing by seed cancels whatever the two runs of one seed share
// (for DA* rows, the run they fine-tune).

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "eval/SeedStatistics.h"
#include "eval/Tables.h"

namespace vln::eval {

/// A row of the paper's tables: table number and PaperRow::key.
struct RowRef {
  int table = 0;
  std::string row;
};

/// "Row `better` beats row `worse`", in the paper's words.
struct PaperFinding {
  RowRef better;      ///< the row the paper finds better
  RowRef worse;       ///< the row it finds worse
  std::string claim;  ///< the paper's sentence (Section 5), LaTeX removed
};

/// Every finding judged, in the order of the paper's text.
const std::vector<PaperFinding>& paperFindings();

/// Split the findings are judged on: the paper's claims are about new
/// environments, and its early stopping uses the same split.
inline constexpr std::string_view kFindingSplit = "val_unseen";
/// Metrics the findings are judged on: the paper's primary metrics ("we
/// will examine success rate and SPL as the primary metrics").
inline const std::vector<std::string> kFindingMetrics = {"SR", "SPL"};

/// One metric of one finding.
struct MetricJudgement {
  std::string metric;
  /// mean and interval of the oriented paired improvement; nullopt when the
  /// rows share no seed with the split or one of them lacks the metric
  std::optional<Interval> improvement;
  Verdict verdict = Verdict::kCannotTell;
  /// the same oriented difference in the paper's numbers; nullopt where
  /// the paper reports none
  std::optional<double> paper_improvement;
};

/// One finding judged on our runs.
struct FindingJudgement {
  const PaperFinding* finding = nullptr;
  std::string better_label;  ///< e.g. "T2 #3 Seq2Seq DA"
  std::string worse_label;
  std::vector<int> seeds;  ///< seeds both rows have with the split
  std::vector<MetricJudgement> metrics;  ///< in the order asked for
};

/// Judges `findings` on `tables` (buildTables(), unfiltered) on `split` and
/// `metrics` (columns of the rows' tables). Throws std::invalid_argument
/// naming the finding when it names a table, row, split or metric the
/// tables lack.
std::vector<FindingJudgement> judgeFindings(
    const std::vector<BuiltTable>& tables,
    const std::vector<PaperFinding>& findings, std::string_view split,
    const std::vector<std::string>& metrics);

/// How many metric judgements of `judgements` reached each verdict (every
/// verdict present, possibly 0).
std::map<Verdict, int> countVerdicts(
    const std::vector<FindingJudgement>& judgements);

/// GitHub Markdown: a heading, what the columns mean, one table line per
/// finding (seeds, paired improvement per metric with the paper's, the
/// verdicts) and the count of each verdict.
std::string renderFindingsMarkdown(
    const std::vector<FindingJudgement>& judgements, std::string_view split);

}  // namespace vln::eval
