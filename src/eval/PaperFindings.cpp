#include "eval/PaperFindings.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "common/Check.h"

namespace vln::eval {
namespace {

// The paper's sentences (Section 5), shared by several findings.
const char* const kBeatsBaselines =
    "Our baseline Seq2Seq model significantly outperforms the random and "
    "hand-crafted baselines, successfully reaching the goal in 20% of "
    "val-unseen episodes.";
const char* const kAblations =
    "All of these ablations under-perform the Seq2Seq baseline.";
const char* const kCmaBeatsSeq2Seq =
    "We find the cross-modal attention model outperforms the Seq2Seq "
    "baseline under all settings for new environments.";
const char* const kDagger =
    "We find DAgger-based training impactful for both the Seq2Seq (row 1 vs "
    "3) and Cross-Modal (row 6 vs 8) models -- improving by 0.03-0.05 SPL in "
    "val-unseen.";
const char* const kPmAugHurt =
    "Contrary to findings in prior work, we observe negative effects from "
    "progress monitor auxiliary loss or data augmentation for both models "
    "(rows 2/4 and 7/9) -- dropping 0.01-0.03 SPL from standard training "
    "(rows 1/6).";
const char* const kAllThree =
    "Despite this, we find combining all three techniques to lead to "
    "significant performance gains for the cross-modal attention model (row "
    "10).";
const char* const kPmAug =
    "We examine the validation performance of PM+Aug (row 11) and find it to "
    "outperform Aug or PM alone (by 0.02-0.03 SPL).";
const char* const kDaStarAug =
    "Finally, we examine the performance of DA*+Aug (row 12) and find that "
    "this outperforms DA (by 0.01-0.02 SPL), but is unable to match "
    "pre-training with the progress monitor and augmented data (row 10).";

// `v` with `decimals` decimals, with its sign when `sign`.
std::string formatNumber(double v, int decimals, bool sign) {
  if (!std::isfinite(v)) return v > 0 ? "+inf" : "-inf";
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), sign ? "%+.*f" : "%.*f", decimals, v);
  return buffer;
}

// Decimals of our paired differences (a few hundredths apart at this
// scale) and of the paper's (its tables print two).
constexpr int kOurDecimals = 3;
constexpr int kPaperDecimals = 2;

size_t indexOf(const std::vector<std::string>& items, std::string_view item,
               const std::string& what, size_t finding) {
  const auto it = std::find(items.begin(), items.end(), item);
  VLN_CHECK_ARG(it != items.end(), "judgeFindings(): finding ", finding + 1,
                " needs ", what, " '", item, "', which its table lacks");
  return static_cast<size_t>(it - items.begin());
}

const BuiltTable& tableOf(const std::vector<BuiltTable>& tables, int number,
                          size_t finding) {
  for (const auto& table : tables)
    if (table.paper->number == number) return table;
  throw std::invalid_argument(strCat("judgeFindings(): finding ", finding + 1,
                                     " names table ", number,
                                     ", which the tables lack"));
}

const TableRow& rowOf(const BuiltTable& table, const std::string& key,
                      size_t finding) {
  const TableRow* row = table.findRow(key);
  VLN_CHECK_ARG(row != nullptr, "judgeFindings(): finding ", finding + 1,
                " names table ", table.paper->number, " row '", key,
                "', which the tables lack");
  return *row;
}

// "T2 #5 Seq2Seq PM+DA*+Aug": Table 2's rows differ in their training
// regimes (the attribute columns), Table 1's in what their keys name.
std::string rowLabel(const PaperTable& table, const PaperRow& row) {
  if (table.number != 2) return strCat("T", table.number, " ", row.key);
  std::string regimes;
  for (size_t i = 0; i < row.attributes.size(); ++i) {
    std::string column = table.attribute_columns[i];
    if (!column.empty() && column.back() == '.') column.pop_back();
    if (row.attributes[i] == kCheck || row.attributes[i] == kCheckStar)
      regimes += (regimes.empty() ? "" : "+") + column +
                 (row.attributes[i] == kCheckStar ? "*" : "");
  }
  return strCat("T2 #", row.key, " ", row.model,
                regimes.empty() ? "" : " " + regimes);
}

// seed -> the split's values of one of our rows
std::map<int, const SplitValues*> valuesBySeed(const TableRow& row,
                                               size_t split) {
  std::map<int, const SplitValues*> out;
  if (!row.ours) return out;
  for (const auto& seed : row.ours->seeds)
    if (seed.splits[split]) out[seed.seed] = &*seed.splits[split];
  return out;
}

std::optional<double> paperValue(const PaperRow& row, size_t split,
                                 size_t metric) {
  const std::string& text = row.values[split][metric];
  if (text == kNone) return std::nullopt;
  return std::stod(text);
}

std::string markdownText(const std::string& text) {
  std::string out;
  for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

}  // namespace

const std::vector<PaperFinding>& paperFindings() {
  static const std::vector<PaperFinding> findings = {
      // Table 1: Seq2Seq against the no-learning baselines and its ablations
      {{1, "Seq2Seq"}, {1, "Random"}, kBeatsBaselines},
      {{1, "Seq2Seq"}, {1, "Hand-Crafted"}, kBeatsBaselines},
      {{1, "Seq2Seq"}, {1, "No Image"}, kAblations},
      {{1, "Seq2Seq"}, {1, "No Depth"}, kAblations},
      {{1, "Seq2Seq"}, {1, "No Vision"}, kAblations},
      {{1, "Seq2Seq"}, {1, "No Instruction"}, kAblations},
      // Table 2: Cross-Modal Attention against Seq2Seq in every regime
      {{2, "6"}, {2, "1"}, kCmaBeatsSeq2Seq},
      {{2, "7"}, {2, "2"}, kCmaBeatsSeq2Seq},
      {{2, "8"}, {2, "3"}, kCmaBeatsSeq2Seq},
      {{2, "9"}, {2, "4"}, kCmaBeatsSeq2Seq},
      {{2, "10"}, {2, "5"}, kCmaBeatsSeq2Seq},
      // the training regimes
      {{2, "3"}, {2, "1"}, kDagger},
      {{2, "8"}, {2, "6"}, kDagger},
      {{2, "1"}, {2, "2"}, kPmAugHurt},
      {{2, "1"}, {2, "4"}, kPmAugHurt},
      {{2, "6"}, {2, "7"}, kPmAugHurt},
      {{2, "6"}, {2, "9"}, kPmAugHurt},
      {{2, "10"}, {2, "6"}, kAllThree},
      {{2, "11"}, {2, "9"}, kPmAug},
      {{2, "11"}, {2, "7"}, kPmAug},
      {{2, "12"}, {2, "8"}, kDaStarAug},
      {{2, "10"}, {2, "12"}, kDaStarAug},
  };
  return findings;
}

std::vector<FindingJudgement> judgeFindings(
    const std::vector<BuiltTable>& tables,
    const std::vector<PaperFinding>& findings, std::string_view split,
    const std::vector<std::string>& metrics) {
  std::vector<FindingJudgement> judgements;
  for (size_t f = 0; f < findings.size(); ++f) {
    const PaperFinding& finding = findings[f];
    VLN_CHECK_ARG(finding.better.table == finding.worse.table,
                  "judgeFindings(): finding ", f + 1,
                  " compares rows of different tables");
    const BuiltTable& table = tableOf(tables, finding.better.table, f);
    const PaperTable& paper = *table.paper;
    const TableRow& better = rowOf(table, finding.better.row, f);
    const TableRow& worse = rowOf(table, finding.worse.row, f);
    const size_t s = indexOf(paper.splits, split, "split", f);

    FindingJudgement judgement;
    judgement.finding = &finding;
    judgement.better_label = rowLabel(paper, *better.paper);
    judgement.worse_label = rowLabel(paper, *worse.paper);

    // the seeds both rows have with the split: the pairs
    const auto betterBySeed = valuesBySeed(better, s);
    const auto worseBySeed = valuesBySeed(worse, s);
    for (const auto& [seed, values] : betterBySeed)
      if (worseBySeed.contains(seed)) judgement.seeds.push_back(seed);

    for (const auto& metric : metrics) {
      const size_t m = indexOf(paper.metrics, metric, "metric", f);
      // positive improvement = the paper's direction
      const double sign = lowerIsBetter(metric) ? -1.0 : 1.0;
      MetricJudgement result;
      result.metric = metric;
      std::vector<double> improvements;
      for (int seed : judgement.seeds) {
        const auto& a = betterBySeed.at(seed)->metrics[m];
        const auto& b = worseBySeed.at(seed)->metrics[m];
        if (a && b) improvements.push_back(sign * (*a - *b));
      }
      // a metric some pair lacks is judged on none, as the tables do
      if (!improvements.empty() &&
          improvements.size() == judgement.seeds.size()) {
        result.improvement = meanInterval(improvements);
        result.verdict = judgeImprovement(*result.improvement);
      }
      const auto paperBetter = paperValue(*better.paper, s, m);
      const auto paperWorse = paperValue(*worse.paper, s, m);
      if (paperBetter && paperWorse)
        result.paper_improvement = sign * (*paperBetter - *paperWorse);
      judgement.metrics.push_back(std::move(result));
    }
    judgements.push_back(std::move(judgement));
  }
  return judgements;
}

std::map<Verdict, int> countVerdicts(
    const std::vector<FindingJudgement>& judgements) {
  std::map<Verdict, int> counts = {{Verdict::kHolds, 0},
                                   {Verdict::kDoesNotHold, 0},
                                   {Verdict::kCannotTell, 0}};
  for (const auto& judgement : judgements)
    for (const auto& metric : judgement.metrics) ++counts[metric.verdict];
  return counts;
}

std::string renderFindingsMarkdown(
    const std::vector<FindingJudgement>& judgements, std::string_view split) {
  std::ostringstream out;
  out << "### Paired differences: the paper's findings on " << split << "\n\n"
      << "Each line is a finding of the paper that one row beats another. "
         "For every seed both rows have (n of them), the improvement is "
         "(better row - worse row) of that seed, positive in the paper's "
         "direction (negated where lower is better); *ours* is its mean over "
         "the seeds ± the half-width of its "
      << static_cast<int>(std::lround(kConfidenceLevel * 100))
      << "% Student t interval (n - 1 degrees of freedom), *paper* the same "
         "difference in the paper's table. The verdict: **holds** when the "
         "interval excludes 0 on the paper's side, **does not hold** when it "
         "excludes 0 on the other side, **cannot tell** when it contains 0 "
         "or n < 2.\n\n";

  // header: the metrics of the first judgement (all share them)
  const std::vector<MetricJudgement> none;
  const auto& metrics = judgements.empty() ? none : judgements[0].metrics;
  out << "| # | Paper's finding | Better (paper) | Worse (paper) | n |";
  for (const auto& metric : metrics)
    out << " " << metric.metric << " ours | " << metric.metric << " paper | "
        << metric.metric << " verdict |";
  out << "\n| --: | :-- | :-- | :-- | --: |";
  for (size_t i = 0; i < metrics.size(); ++i) out << " --: | --: | :-- |";
  out << "\n";

  // one line per finding
  for (size_t i = 0; i < judgements.size(); ++i) {
    const FindingJudgement& j = judgements[i];
    out << "| " << i + 1 << " | " << markdownText(j.finding->claim) << " | "
        << j.better_label << " | " << j.worse_label << " | " << j.seeds.size()
        << " |";
    for (const auto& metric : j.metrics) {
      std::string ours = "-";
      if (metric.improvement) {
        ours = formatNumber(metric.improvement->mean, kOurDecimals,
                            /*sign=*/true);
        if (metric.improvement->n > 1 &&
            std::isfinite(metric.improvement->half_width))
          ours += " ± " + formatNumber(metric.improvement->half_width,
                                       kOurDecimals, /*sign=*/false);
      }
      const std::string paper =
          metric.paper_improvement
              ? formatNumber(*metric.paper_improvement, kPaperDecimals,
                             /*sign=*/true)
              : "-";
      out << " " << ours << " | " << paper << " | "
          << verdictName(metric.verdict) << " |";
    }
    out << "\n";
  }

  // the totals
  auto counts = countVerdicts(judgements);
  int total = 0;
  for (const auto& [verdict, n] : counts) total += n;
  out << "\nVerdicts on " << split << " (" << total
      << " in all): " << counts[Verdict::kHolds] << " hold, "
      << counts[Verdict::kDoesNotHold] << " do not hold, "
      << counts[Verdict::kCannotTell] << " cannot tell.\n";
  return out.str();
}

}  // namespace vln::eval
