#pragma once
// The numbers the paper reports (Krantz et al., ECCV 2020), transcribed
// verbatim from its LaTeX source: Table 1 (no-learning baselines and input
// ablations), Table 2 (training regimes of Seq2Seq and Cross-Modal
// Attention) and Table 3 (nav-graph VLN comparison). The tables builder
// prints them beside our runs. Tables 1 and 2 also get columns for the two
// metrics VLN-CE's code reports and the paper does not (addedMetric()).

#include <string>
#include <string_view>
#include <vector>

namespace vln::eval {

/// Attribute token meaning "checkmark" in PaperRow::attributes.
inline constexpr std::string_view kCheck = "x";
/// Attribute token meaning "checkmark with asterisk" (fine-tuning).
inline constexpr std::string_view kCheckStar = "x*";
/// Token of an absent attribute or an unreported metric.
inline constexpr std::string_view kNone = "-";

/// One row of a paper table.
struct PaperRow {
  /// Stable key our runs use to claim the row (run.json "rows[].row"):
  /// Table 1 "Random", "Hand-Crafted", "Seq2Seq", "No Image", "No Depth",
  /// "No Vision", "No Instruction"; Table 2 "1".."12"; Table 3
  /// "VLN-Seq2Seq", "Self-Monitoring", "RCM", "Back-Translation",
  /// "Cross-Modal".
  std::string key;
  /// Model name as printed.
  std::string model;
  /// One token per PaperTable::attribute_columns: free text ("RGBD") or
  /// kCheck / kCheckStar / kNone.
  std::vector<std::string> attributes;
  /// values[split][metric] as printed in the paper ("0.495", "10.1", or
  /// kNone where the paper reports nothing).
  std::vector<std::vector<std::string>> values;
  /// False for other authors' nav-graph models (Table 3 top rows): shown
  /// for reference only, no run of ours can claim them.
  bool reproducible = true;
};

/// One paper table.
struct PaperTable {
  int number = 0;
  std::string caption;
  std::vector<std::string>
      attribute_columns;            ///< e.g. {"Vision", "Instr.", "History"}
  std::vector<std::string> splits;  ///< e.g. {"val_seen", "val_unseen"}
  /// e.g. {"TL", "NE", "nDTW", "OS", "SR", "SPL", "ONE", "OSPL"}
  std::vector<std::string> metrics;
  std::vector<PaperRow> rows;
  /// The row with `key`, or nullptr.
  const PaperRow* findRow(std::string_view key) const;
};

/// Paper Table `number` (1, 2 or 3); throws std::invalid_argument otherwise.
const PaperTable& paperTable(int number);

/// Key in our stats files of a metric column: TL -> path_length,
/// NE -> distance_to_goal, nDTW -> ndtw, OS -> oracle_success,
/// SR -> success, SPL -> spl, ONE -> oracle_navigation_error,
/// OSPL -> oracle_spl. Throws std::invalid_argument otherwise.
std::string_view metricStatsKey(std::string_view metric);

/// True when lower is better for the metric (TL, NE, ONE).
bool lowerIsBetter(std::string_view metric);

/// True for the columns of Tables 1 and 2 that VLN-CE's code reports and
/// the paper does not (ONE: oracle navigation error, OSPL: oracle SPL):
/// the paper's rows show kNone for them, and so do our stats files written
/// before these metrics existed.
bool addedMetric(std::string_view metric);

}  // namespace vln::eval
