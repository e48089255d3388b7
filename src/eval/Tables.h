#pragma once
// Rebuilds the paper's Tables 1-3 from our result files, each paper row
// followed by ours, as Markdown and LaTeX. Numbers are only ever read from
// files: a row without a run, or a split without its stats file, is printed
// as "missing"; a metric a stats file lacks (ONE and OSPL in files written
// before they existed) as "-".
//
// Several runs may claim one row, one per training seed: the row then
// prints, per metric, the mean over seeds and the half-width of its 95%
// Student t interval ("0.12 ± 0.03", SeedStatistics.h), and a column "n"
// the number of seeds; a single seed prints its value and n = 1.
//
// Layout of the results directory: one folder per run, at any depth (the
// paper reproduction writes <runsDir>/<experiment>/seed<S>/):
//
//   <run>/run.json
//   <run>/stats_ckpt_<ckpt>_val_seen.json       Tables 1 and 2
//   <run>/stats_ckpt_<ckpt>_val_unseen.json     Tables 1 and 2
//   <run>/navgraph_stats_ckpt_<ckpt>_<split>.json
//                       Table 3, split val_seen, val_unseen or test
//
// run.json, every field required unless noted:
//
//   {"model": "Seq2Seq",               display name
//    "rows": [{"table": 1, "row": "Seq2Seq"}, {"table": 2, "row": "1"}],
//                                      paper rows this run reproduces
//                                      (keys: PaperRow::key)
//    "seed": 0,                        optional (default 0, the default of
//                                      trainer.seed): the run's training
//                                      seed; runs claiming one row need
//                                      distinct seeds
//    "checkpoint": 14,                 index of the chosen checkpoint
//    "config": "configs/seq2seq.yaml", config the run used
//    "command": "build/bin/train ...", command that produced it
//    "vision": "RGBD",                 Table 1: "RGBD", "RGB", "D" or "-"
//    "instruction": true,              Table 1
//    "history": true,                  Table 1
//    "pm": false,                      Table 2: progress monitor
//    "da": "none",                     Table 2: "none", "dagger" or
//                                      "dagger_finetune"
//    "aug": false,                     Table 2: augmented data
//    "notes": "..."}                   optional, not printed
//
// Attributes a run's tables do not print may be omitted.
// Folders without run.json are searched for runs below them.

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "eval/PaperResults.h"
#include "eval/SeedStatistics.h"

namespace vln::eval {

/// Parsed run.json of one run.
struct RunInfo {
  /// path of the folder relative to the results directory, '/'-separated
  /// ("cma/seed1"); the folder's name when read on its own
  std::string name;
  std::filesystem::path dir;  ///< the folder
  std::string model;
  std::vector<std::pair<int, std::string>> rows;  ///< (table, row key)
  int seed = 0;
  int checkpoint = 0;
  std::string config;
  std::string command;
  std::string vision = "-";
  bool instruction = false;
  bool history = false;
  bool pm = false;
  std::string da = "none";
  bool aug = false;
};

/// Reads `<runDir>/run.json`; throws std::invalid_argument naming the file
/// and the field (unknown table or row key, wrong types, missing fields,
/// attribute values outside the allowed sets).
RunInfo readRunInfo(const std::filesystem::path& runDir);

/// One split of one run, read from its stats file.
struct SplitValues {
  /// per PaperTable::metrics; nullopt for a metric the file lacks (only
  /// addedMetric() columns may be absent)
  std::vector<std::optional<double>> metrics;
  int num_episodes = 0;
};

/// One run (one seed) of a row.
struct SeedRun {
  std::string run;  ///< RunInfo::name
  int seed = 0;
  int checkpoint = 0;
  std::string config;
  std::string command;
  /// per PaperTable::splits; nullopt when the split's stats file is missing
  std::vector<std::optional<SplitValues>> splits;
};

/// Our side of a table row: every seed that claims it, and per metric the
/// mean and interval over those seeds.
struct OurRow {
  std::string model;
  std::vector<std::string> attributes;  ///< tokens as in PaperRow::attributes
  std::vector<SeedRun> seeds;           ///< ascending seed
  /// seeds_with_split[split]: seeds that have the split's stats file
  std::vector<int> seeds_with_split;
  /// cells[split][metric]: meanInterval() over the seeds with the split;
  /// nullopt when no seed has the split (printed "missing") or one of them
  /// lacks the metric (printed "-")
  std::vector<std::vector<std::optional<Interval>>> cells;
};

/// A paper row and, when some run claims it, ours.
struct TableRow {
  const PaperRow* paper = nullptr;
  std::optional<OurRow> ours;
};

/// One rebuilt table.
struct BuiltTable {
  const PaperTable* paper = nullptr;
  std::vector<TableRow> rows;  ///< paper order
  /// The row with paper key `key`, or nullptr (also when filtered out).
  const TableRow* findRow(std::string_view key) const;
};

/// Reads every run under `runsDir` and fills Tables 1, 2 and 3. Throws
/// std::runtime_error when `runsDir` is not a directory and
/// std::invalid_argument for malformed run or stats files, for two runs
/// claiming the same row with the same seed, and for runs of one row that
/// disagree on the model or its attributes (naming both files).
std::vector<BuiltTable> buildTables(const std::filesystem::path& runsDir);

/// Only the rows some run claims (each still with its paper row), and only
/// the tables left with a row: what a job that ran a few rows prints.
std::vector<BuiltTable> claimedRowsOnly(std::vector<BuiltTable> tables);

/// GitHub Markdown: a heading, one table (paper rows, then "ours" rows with
/// a reference number and the number of seeds), and the references citing
/// each run's seed, checkpoint, config and command.
std::string renderMarkdown(const BuiltTable& table);
/// A LaTeX table (booktabs) with the same content; needs amssymb for
/// \checkmark.
std::string renderLatex(const BuiltTable& table);

/// Writes every table as Markdown to `markdownFile` and as LaTeX beside it
/// (the same path with the extension .tex), atomically, each headed by a
/// comment saying they were generated by `generatedBy`; returns the two
/// paths. Throws std::invalid_argument when `markdownFile` ends in .tex.
std::pair<std::filesystem::path, std::filesystem::path> writeTables(
    const std::vector<BuiltTable>& tables,
    const std::filesystem::path& markdownFile, const std::string& generatedBy);

}  // namespace vln::eval
