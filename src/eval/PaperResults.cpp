#include "eval/PaperResults.h"

#include <algorithm>

#include "common/Check.h"
#include "rollout/Metrics.h"

namespace vln::eval {
namespace {

using Values = std::vector<std::vector<std::string>>;

const std::string kX(kCheck);
const std::string kXs(kCheckStar);
const std::string kNo(kNone);

// Metric columns of Tables 1 and 2: the paper's six, then the two VLN-CE's
// code reports (habitat_extensions/measures.py) and the paper does not.
const std::vector<std::string> kPaperMetrics = {"TL", "NE", "nDTW",
                                                "OS", "SR", "SPL"};
const std::vector<std::string> kAddedMetrics = {"ONE", "OSPL"};

// Appends the added metrics to a table transcribed with the paper's
// columns: a column each, kNone in every paper row.
void appendAddedMetrics(PaperTable& t) {
  t.metrics.insert(t.metrics.end(), kAddedMetrics.begin(), kAddedMetrics.end());
  for (auto& row : t.rows)
    for (auto& split : row.values)
      split.insert(split.end(), kAddedMetrics.size(), kNo);
}

// Table 1 of the paper (\label{tab:ablate}), rows top to bottom.
PaperTable makeTable1() {
  PaperTable t;
  t.number = 1;
  t.caption =
      "No-learning baselines and input modality ablations for the baseline "
      "sequence-to-sequence model.";
  t.attribute_columns = {"Vision", "Instr.", "History"};
  t.splits = {"val_seen", "val_unseen"};
  t.metrics = kPaperMetrics;
  t.rows = {
      {"Random",
       "Random",
       {kNo, kNo, kNo},
       Values{{"3.54", "10.20", "0.28", "0.04", "0.02", "0.02"},
              {"3.74", "9.51", "0.30", "0.04", "0.03", "0.02"}}},
      {"Hand-Crafted",
       "Hand-Crafted",
       {kNo, kNo, kNo},
       Values{{"3.83", "9.56", "0.33", "0.05", "0.04", "0.04"},
              {"3.71", "10.34", "0.30", "0.04", "0.03", "0.02"}}},
      {"Seq2Seq",
       "Seq2Seq",
       {"RGBD", kX, kX},
       Values{{"8.40", "8.54", "0.45", "0.35", "0.25", "0.24"},
              {"7.67", "8.94", "0.43", "0.25", "0.20", "0.18"}}},
      {"No Image",
       "-- No Image",
       {"D", kX, kX},
       Values{{"7.77", "8.55", "0.46", "0.31", "0.24", "0.23"},
              {"7.87", "9.09", "0.41", "0.23", "0.17", "0.15"}}},
      {"No Depth",
       "-- No Depth",
       {"RGB", kX, kX},
       Values{{"4.93", "10.76", "0.29", "0.10", "0.03", "0.03"},
              {"5.54", "9.89", "0.31", "0.11", "0.04", "0.04"}}},
      {"No Vision",
       "-- No Vision",
       {kNo, kX, kX},
       Values{{"4.26", "11.07", "0.26", "0.03", "0.00", "0.00"},
              {"4.68", "10.06", "0.30", "0.07", "0.00", "0.00"}}},
      {"No Instruction",
       "-- No Instruction",
       {"RGBD", kNo, kX},
       Values{{"7.86", "9.09", "0.42", "0.26", "0.18", "0.17"},
              {"7.27", "9.03", "0.42", "0.22", "0.17", "0.16"}}},
  };
  appendAddedMetrics(t);
  return t;
}

// Table 2 of the paper (\label{tab:results}); x* marks DAgger fine-tuning.
PaperTable makeTable2() {
  PaperTable t;
  t.number = 2;
  t.caption =
      "Performance in VLN-CE of Seq2Seq and Cross-Modal Attention with "
      "progress monitor (PM), DAgger (DA, * = fine-tuning) and data "
      "augmentation (Aug.).";
  t.attribute_columns = {"PM", "DA", "Aug."};
  t.splits = {"val_seen", "val_unseen"};
  t.metrics = kPaperMetrics;
  const std::string s2s = "Seq2Seq";
  const std::string cma = "Cross-Modal Attention";
  t.rows = {
      {"1",
       s2s,
       {kNo, kNo, kNo},
       Values{{"8.40", "8.54", "0.45", "0.35", "0.25", "0.24"},
              {"7.67", "8.94", "0.43", "0.25", "0.20", "0.18"}}},
      {"2",
       s2s,
       {kX, kNo, kNo},
       Values{{"8.34", "8.48", "0.47", "0.32", "0.22", "0.21"},
              {"8.93", "9.28", "0.40", "0.28", "0.17", "0.15"}}},
      {"3",
       s2s,
       {kNo, kX, kNo},
       Values{{"9.32", "7.09", "0.53", "0.44", "0.34", "0.32"},
              {"8.46", "7.92", "0.48", "0.35", "0.26", "0.23"}}},
      {"4",
       s2s,
       {kNo, kNo, kX},
       Values{{"8.23", "7.76", "0.51", "0.34", "0.26", "0.25"},
              {"7.22", "8.70", "0.44", "0.26", "0.19", "0.17"}}},
      {"5",
       s2s,
       {kX, kXs, kX},
       Values{{"9.37", "7.02", "0.54", "0.46", "0.33", "0.31"},
              {"9.32", "7.77", "0.47", "0.37", "0.25", "0.22"}}},
      {"6",
       cma,
       {kNo, kNo, kNo},
       Values{{"8.26", "7.81", "0.49", "0.38", "0.27", "0.25"},
              {"7.71", "8.14", "0.47", "0.31", "0.23", "0.22"}}},
      {"7",
       cma,
       {kX, kNo, kNo},
       Values{{"8.51", "8.17", "0.47", "0.35", "0.28", "0.26"},
              {"7.87", "8.72", "0.44", "0.28", "0.21", "0.19"}}},
      {"8",
       cma,
       {kNo, kX, kNo},
       Values{{"8.90", "7.40", "0.52", "0.42", "0.33", "0.31"},
              {"8.12", "8.00", "0.48", "0.33", "0.27", "0.25"}}},
      {"9",
       cma,
       {kNo, kNo, kX},
       Values{{"8.50", "8.05", "0.49", "0.36", "0.26", "0.24"},
              {"7.58", "8.65", "0.45", "0.28", "0.21", "0.19"}}},
      {"10",
       cma,
       {kX, kXs, kX},
       Values{{"9.26", "7.12", "0.54", "0.46", "0.37", "0.35"},
              {"8.64", "7.37", "0.51", "0.40", "0.32", "0.30"}}},
      {"11",
       cma,
       {kX, kNo, kX},
       Values{{"8.49", "8.29", "0.47", "0.36", "0.27", "0.25"},
              {"7.68", "8.42", "0.46", "0.30", "0.24", "0.22"}}},
      {"12",
       cma,
       {kNo, kXs, kX},
       Values{{"9.32", "6.76", "0.55", "0.47", "0.37", "0.33"},
              {"8.27", "7.76", "0.50", "0.37", "0.29", "0.26"}}},
  };
  appendAddedMetrics(t);
  return t;
}

// Table 3 of the paper (\label{tab:test}): VLN (nav-graph) metrics; the top
// four rows use the nav-graph at train and test time.
PaperTable makeTable3() {
  PaperTable t;
  t.number = 3;
  t.caption =
      "Comparison on the VLN validation and test sets with nav-graph "
      "models; our continuous paths are converted to nav-graph "
      "trajectories.";
  t.attribute_columns = {"Nav-graph"};
  t.splits = {"val_seen", "val_unseen", "test"};
  t.metrics = {"TL", "NE", "OS", "SR", "SPL"};
  t.rows = {
      {"VLN-Seq2Seq",
       "VLN-Seq2Seq",
       {kX},
       Values{{"11.33", "6.01", "0.52", "0.38", kNo},
              {"8.39", "7.81", "0.28", "0.21", kNo},
              {"8.13", "7.85", "0.27", "0.20", "0.18"}},
       /*reproducible=*/false},
      {"Self-Monitoring",
       "Self-Monitoring",
       {kX},
       Values{{kNo, "3.18", "0.77", "0.68", "0.58"},
              {kNo, "5.41", "0.68", "0.47", "0.34"},
              {"18.04", "5.67", "0.59", "0.48", "0.35"}},
       /*reproducible=*/false},
      {"RCM",
       "RCM",
       {kX},
       Values{{"10.65", "3.53", "0.75", "0.66", kNo},
              {"11.46", "6.09", "0.50", "0.42", kNo},
              {"11.97", "6.12", "0.495", "0.43", "0.38"}},
       /*reproducible=*/false},
      {"Back-Translation",
       "Back-Translation",
       {kX},
       Values{{"10.1", "4.71", kNo, "0.55", "0.53"},
              {"9.37", "5.49", kNo, "0.46", "0.43"},
              {"11.7", kNo, kNo, "0.51", "0.47"}},
       /*reproducible=*/false},
      {"Cross-Modal",
       "Cross-Modal (PM+DA*+Aug.)",
       {kNo},
       Values{{"6.92", "7.77", "0.30", "0.25", "0.23"},
              {"7.42", "8.17", "0.28", "0.22", "0.20"},
              {"9.47", "8.55", "0.32", "0.24", "0.21"}}},
  };
  return t;
}

}  // namespace

const PaperRow* PaperTable::findRow(std::string_view key) const {
  for (const auto& row : rows)
    if (row.key == key) return &row;
  return nullptr;
}

const PaperTable& paperTable(int number) {
  static const PaperTable t1 = makeTable1();
  static const PaperTable t2 = makeTable2();
  static const PaperTable t3 = makeTable3();
  switch (number) {
    case 1:
      return t1;
    case 2:
      return t2;
    case 3:
      return t3;
    default:
      throw std::invalid_argument(strCat(
          "paperTable(): the paper has tables 1, 2 and 3, got ", number));
  }
}

std::string_view metricStatsKey(std::string_view metric) {
  if (metric == "TL") return "path_length";
  if (metric == "NE") return "distance_to_goal";
  if (metric == "nDTW") return "ndtw";
  if (metric == "OS") return "oracle_success";
  if (metric == "SR") return "success";
  if (metric == "SPL") return "spl";
  if (metric == "ONE") return "oracle_navigation_error";
  if (metric == "OSPL") return "oracle_spl";
  throw std::invalid_argument(
      strCat("metricStatsKey(): unknown metric column '", metric, "'"));
}

bool lowerIsBetter(std::string_view metric) {
  return metric == "TL" || metric == "NE" || metric == "ONE";
}

bool addedMetric(std::string_view metric) {
  // one list of the metrics older files lack: rollout's
  return rollout::addedLaterMetric(metricStatsKey(metric));
}

}  // namespace vln::eval
