#pragma once
// Rebuilds the paper's Tables 1-3 from our result files, each paper row
// followed by ours, as Markdown and LaTeX. Numbers are only ever read from
// files: a row without a run, or a split without its stats file, is printed
// as "missing".
//
// Layout of the results directory (one folder per run):
//
//   <runsDir>/<run>/run.json
//   <runsDir>/<run>/stats_ckpt_<ckpt>_val_seen.json       Tables 1 and 2
//   <runsDir>/<run>/stats_ckpt_<ckpt>_val_unseen.json     Tables 1 and 2
//   <runsDir>/<run>/navgraph_stats_ckpt_<ckpt>_<split>.json
//                       Table 3, split val_seen, val_unseen or test
//
// run.json, every field required unless noted:
//
//   {"model": "Seq2Seq",               display name
//    "rows": [{"table": 1, "row": "Seq2Seq"}, {"table": 2, "row": "1"}],
//                                      paper rows this run reproduces
//                                      (keys: PaperRow::key)
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
// Sub-folders without run.json are ignored.

#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "eval/PaperResults.h"

namespace vln::eval {

/// Parsed run.json of one run.
struct RunInfo {
  std::string name;           ///< folder name under the results directory
  std::filesystem::path dir;  ///< the folder
  std::string model;
  std::vector<std::pair<int, std::string>> rows;  ///< (table, row key)
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

/// Our side of a table row.
struct OurRow {
  std::string run;  ///< run name
  std::string model;
  std::vector<std::string> attributes;  ///< tokens as in PaperRow::attributes
  /// values[split][metric]; nullopt for a split whose stats file is missing
  std::vector<std::optional<std::vector<double>>> values;
  std::vector<int> num_episodes;  ///< per split, 0 when missing
  int checkpoint = 0;
  std::string config;
  std::string command;
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
};

/// Reads every run under `runsDir` and fills Tables 1, 2 and 3. Throws
/// std::runtime_error when `runsDir` is not a directory and
/// std::invalid_argument for malformed run or stats files and for two runs
/// claiming the same row (naming both).
std::vector<BuiltTable> buildTables(const std::filesystem::path& runsDir);

/// GitHub Markdown: a heading, one table (paper rows, then "ours" rows with
/// a reference number), and the references citing each run's config and
/// command.
std::string renderMarkdown(const BuiltTable& table);
/// A LaTeX table (booktabs) with the same content; needs amssymb for
/// \checkmark.
std::string renderLatex(const BuiltTable& table);

/// Writes `<outDir>/tables.md` and `<outDir>/tables.tex` (atomically) with
/// every table; returns the two paths.
std::pair<std::filesystem::path, std::filesystem::path> writeTables(
    const std::vector<BuiltTable>& tables, const std::filesystem::path& outDir);

}  // namespace vln::eval
