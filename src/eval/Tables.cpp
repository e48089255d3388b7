#include "eval/Tables.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "common/Check.h"
#include "common/FileIo.h"
#include "common/Json.h"
#include "eval/NavGraphEval.h"
#include "rollout/Metrics.h"

namespace vln::eval {
namespace {

const std::set<std::string> kRunKeys = {
    "model",   "rows",   "seed",        "checkpoint", "config",
    "command", "vision", "instruction", "history",    "pm",
    "da",      "aug",    "notes"};
const std::vector<std::string> kVisionValues = {"RGBD", "RGB", "D", "-"};
const std::vector<std::string> kDaValues = {"none", "dagger",
                                            "dagger_finetune"};

std::string joined(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : ", ") + item;
  return out;
}

std::vector<std::string> rowKeys(const PaperTable& table) {
  std::vector<std::string> keys;
  for (const auto& row : table.rows)
    if (row.reproducible) keys.push_back("'" + row.key + "'");
  return keys;
}

template <class T>
T optionalField(const nlohmann::json& json, const char* key, T fallback,
                bool required, const std::string& where, const char* why) {
  if (!json.contains(key)) {
    VLN_CHECK_ARG(!required, where, ": field '", key, "' is missing (", why,
                  ")");
    return fallback;
  }
  return common::requireField<T>(json, key, where);
}

// One run's attributes as the tokens of table `number`'s attribute columns.
std::vector<std::string> runAttributes(const RunInfo& run, int number) {
  auto check = [](bool on) { return std::string(on ? kCheck : kNone); };
  switch (number) {
    case 1:
      return {run.vision, check(run.instruction), check(run.history)};
    case 2:
      return {check(run.pm),
              run.da == "none"     ? std::string(kNone)
              : run.da == "dagger" ? std::string(kCheck)
                                   : std::string(kCheckStar),
              check(run.aug)};
    default:
      return {std::string(kNone)};  // our model never uses the nav-graph
  }
}

// The metric values of one split, or nullopt when its stats file is absent.
std::optional<SplitValues> splitValues(const RunInfo& run,
                                       const PaperTable& table,
                                       const std::string& split) {
  nlohmann::json stats;
  SplitValues values;
  std::string where;
  if (table.number == 3) {
    const auto file = run.dir / graphStatsFileName(run.checkpoint, split);
    if (!std::filesystem::exists(file)) return std::nullopt;
    const GraphSplitStats s = readGraphStatsFile(file);
    stats = graphStatsToJson(s);
    values.num_episodes = s.num_episodes;
    where = file.string();
  } else {
    // read here, not by rollout::readStatsFile(): files written before the
    // added metrics existed lack them and must still print
    const auto file = run.dir / rollout::statsFileName(run.checkpoint, split);
    if (!std::filesystem::exists(file)) return std::nullopt;
    where = file.string();
    stats = common::readJsonFile(file);
    values.num_episodes =
        common::requireField<int>(stats, "num_episodes", where);
    VLN_CHECK_ARG(values.num_episodes > 0, where,
                  ": field 'num_episodes' must be positive, got ",
                  values.num_episodes);
  }
  for (const auto& metric : table.metrics) {
    const std::string key(metricStatsKey(metric));
    const auto it = stats.find(key);
    if (it == stats.end()) {
      VLN_CHECK_ARG(addedMetric(metric), where, ": field '", key,
                    "' is missing");
      values.metrics.push_back(std::nullopt);
    } else if (it->is_null()) {
      // JSON has no infinity: the stats writers store a non-finite mean
      // (an unreachable goal's distance) as null
      values.metrics.push_back(std::numeric_limits<double>::infinity());
    } else {
      VLN_CHECK_ARG(it->is_number(), where, ": field '", key,
                    "' must be a number, got ", it->dump());
      values.metrics.push_back(it->get<double>());
    }
  }
  return values;
}

// Mean and interval of every metric of every split over a row's seeds.
void aggregateSeeds(const PaperTable& table, OurRow& ours) {
  ours.seeds_with_split.assign(table.splits.size(), 0);
  ours.cells.assign(table.splits.size(), {});
  for (size_t s = 0; s < table.splits.size(); ++s) {
    std::vector<const SplitValues*> present;
    for (const auto& seed : ours.seeds)
      if (seed.splits[s]) present.push_back(&*seed.splits[s]);
    ours.seeds_with_split[s] = static_cast<int>(present.size());
    for (size_t m = 0; m < table.metrics.size(); ++m) {
      std::vector<double> values;
      for (const SplitValues* split : present)
        if (split->metrics[m]) values.push_back(*split->metrics[m]);
      // a metric some seed lacks is not averaged over the others: the cell
      // would silently rest on fewer seeds than the row says
      const bool complete = !present.empty() && values.size() == present.size();
      ours.cells[s].push_back(complete ? std::optional(meanInterval(values))
                                       : std::nullopt);
    }
  }
}

std::string formatValue(double v) {
  if (!std::isfinite(v)) return "inf";
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.2f", v);
  return buffer;
}

std::string splitTitle(const std::string& split) {
  if (split == "val_seen") return "Val-Seen";
  if (split == "val_unseen") return "Val-Unseen";
  if (split == "test") return "Test";
  return split;
}

// --- Markdown ----------------------------------------------------------------

std::string mdToken(const std::string& token) {
  if (token == kCheck) return "✓";
  if (token == kCheckStar) return "✓*";
  return token;
}

// Text inside a Markdown table cell or inline code: no pipes, no backticks.
std::string mdCode(std::string text) {
  std::string out;
  for (char c : text) {
    if (c == '`')
      out += '\'';
    else if (c == '|')
      out += "\\|";
    else if (c == '\n')
      out += ' ';
    else
      out += c;
  }
  return "`" + out + "`";
}

// --- LaTeX -------------------------------------------------------------------

std::string texEscape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '\\':
        out += "\\textbackslash{}";
        break;
      case '_':
      case '%':
      case '&':
      case '#':
      case '$':
      case '{':
      case '}':
        out += '\\';
        out += c;
        break;
      case '~':
        out += "\\textasciitilde{}";
        break;
      case '^':
        out += "\\textasciicircum{}";
        break;
      case '\n':
        out += ' ';
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string texToken(const std::string& token) {
  if (token == kCheck) return "\\checkmark";
  if (token == kCheckStar) return "\\checkmark$^*$";
  return texEscape(token);
}

bool numbered(const PaperTable& table) { return table.number == 2; }

// Plus-minus sign between a mean and its half-width, per format.
constexpr std::string_view kMdPlusMinus = " ± ";
constexpr std::string_view kTexPlusMinus = " $\\pm$ ";

// One of our metric cells: "missing" without the split, kNone without the
// metric, the value for one seed, "mean ± half-width" for several.
std::string formatCell(const OurRow& ours, size_t split, size_t metric,
                       std::string_view plusMinus) {
  if (ours.seeds_with_split[split] == 0) return "missing";
  const std::optional<Interval>& cell = ours.cells[split][metric];
  if (!cell) return std::string(kNone);
  if (cell->n == 1 || !std::isfinite(cell->mean))
    return formatValue(cell->mean);
  return strCat(formatValue(cell->mean), plusMinus,
                formatValue(cell->half_width));
}

// The "n" cell: seeds claiming the row, and the splits fewer of them have.
std::string seedCount(const OurRow& ours, const PaperTable& table) {
  const int n = static_cast<int>(ours.seeds.size());
  std::string partial;
  for (size_t s = 0; s < table.splits.size(); ++s)
    if (ours.seeds_with_split[s] != n)
      partial += strCat(partial.empty() ? "" : ", ", table.splits[s], " ",
                        ours.seeds_with_split[s]);
  return partial.empty() ? std::to_string(n) : strCat(n, " (", partial, ")");
}

// The folder holding a row's runs when several share one (<experiment> of
// <experiment>/seed<S>), else the run names.
std::string sourceName(const OurRow& ours) {
  const auto parent = std::filesystem::path(ours.seeds[0].run).parent_path();
  bool shared = ours.seeds.size() > 1 && !parent.empty();
  for (const auto& seed : ours.seeds)
    shared &= std::filesystem::path(seed.run).parent_path() == parent;
  if (shared) return parent.generic_string();
  std::vector<std::string> names;
  for (const auto& seed : ours.seeds) names.push_back(seed.run);
  return joined(names);
}

// A row's footnote: each run with its seed and checkpoint, the episodes
// per split, the configs and the commands. `text` escapes prose, `code`
// formats a path or a command.
template <class Text, class Code>
std::string reference(const OurRow& ours, const PaperTable& table, Text text,
                      Code code) {
  const bool several = ours.seeds.size() > 1;
  std::vector<std::string> runs, configs, commands;
  for (const auto& seed : ours.seeds) {
    runs.push_back(text(strCat(seed.run, " (seed ", seed.seed, ", checkpoint ",
                               seed.checkpoint, ")")));
    if (std::find(configs.begin(), configs.end(), code(seed.config)) ==
        configs.end())
      configs.push_back(code(seed.config));
    commands.push_back(code(seed.command));
  }
  std::vector<std::string> episodes;
  for (size_t s = 0; s < table.splits.size(); ++s) {
    std::vector<std::string> counts;
    for (const auto& seed : ours.seeds) {
      if (!seed.splits[s]) continue;
      const std::string n = std::to_string(seed.splits[s]->num_episodes);
      if (std::find(counts.begin(), counts.end(), n) == counts.end())
        counts.push_back(n);
    }
    std::string list;
    for (const auto& n : counts) list += (list.empty() ? "" : "/") + n;
    episodes.push_back(
        text(strCat(table.splits[s], " ", list.empty() ? "missing" : list)));
  }
  return strCat(
      several ? "runs " : "run ", joined(runs), "; episodes ", joined(episodes),
      configs.size() > 1 ? "; configs " : "; config ", joined(configs),
      several ? "; commands " : "; command ", joined(commands));
}

std::string identity(const std::string& text) { return text; }

std::string texCode(const std::string& text) {
  return "\\texttt{" + texEscape(text) + "}";
}

}  // namespace

// ---------------------------------------------------------------------------
// reading runs
// ---------------------------------------------------------------------------

RunInfo readRunInfo(const std::filesystem::path& runDir) {
  const auto file = runDir / "run.json";
  const std::string where = file.string();
  const nlohmann::json json = common::readJsonFile(file);
  VLN_CHECK_ARG(json.is_object(), where, ": expected a JSON object, got ",
                json.type_name());
  for (const auto& [key, value] : json.items())
    VLN_CHECK_ARG(kRunKeys.contains(key), where, ": unknown field '", key, "'");

  RunInfo run;
  run.name = runDir.filename().string();
  if (run.name.empty()) run.name = runDir.parent_path().filename().string();
  run.dir = runDir;
  run.model = common::requireField<std::string>(json, "model", where);
  run.seed = optionalField<int>(json, "seed", 0, /*required=*/false, where, "");
  VLN_CHECK_ARG(run.seed >= 0, where, ": field 'seed' must be >= 0, got ",
                run.seed);
  run.checkpoint = common::requireField<int>(json, "checkpoint", where);
  VLN_CHECK_ARG(run.checkpoint >= 0, where,
                ": field 'checkpoint' must be >= 0, got ", run.checkpoint);
  run.config = common::requireField<std::string>(json, "config", where);
  run.command = common::requireField<std::string>(json, "command", where);
  VLN_CHECK_ARG(!run.config.empty(), where, ": field 'config' is empty");
  VLN_CHECK_ARG(!run.command.empty(), where, ": field 'command' is empty");

  // claimed rows
  const auto rows = common::requireField<nlohmann::json>(json, "rows", where);
  VLN_CHECK_ARG(rows.is_array() && !rows.empty(), where,
                ": field 'rows' must be a non-empty array, got ", rows.dump());
  bool inTable1 = false, inTable2 = false;
  for (size_t i = 0; i < rows.size(); ++i) {
    const std::string ctx = strCat(where, ": field 'rows[", i, "]'");
    const int number = common::requireField<int>(rows[i], "table", ctx);
    VLN_CHECK_ARG(number >= 1 && number <= 3, ctx,
                  ": 'table' must be 1, 2 or 3, got ", number);
    const auto key = common::requireField<std::string>(rows[i], "row", ctx);
    const PaperTable& table = paperTable(number);
    const PaperRow* paperRow = table.findRow(key);
    VLN_CHECK_ARG(paperRow != nullptr, ctx, ": table ", number, " has no row '",
                  key, "'; rows are ", joined(rowKeys(table)));
    VLN_CHECK_ARG(paperRow->reproducible, ctx, ": table ", number, " row '",
                  key,
                  "' is another paper's nav-graph model, shown for "
                  "reference only");
    run.rows.emplace_back(number, key);
    inTable1 |= number == 1;
    inTable2 |= number == 2;
  }

  // attributes, required by the tables that print them
  run.vision = optionalField<std::string>(json, "vision", "-", inTable1, where,
                                          "Table 1 rows need it");
  VLN_CHECK_ARG(std::find(kVisionValues.begin(), kVisionValues.end(),
                          run.vision) != kVisionValues.end(),
                where, ": field 'vision' must be one of ",
                joined(kVisionValues), ", got '", run.vision, "'");
  run.instruction = optionalField<bool>(json, "instruction", false, inTable1,
                                        where, "Table 1 rows need it");
  run.history = optionalField<bool>(json, "history", false, inTable1, where,
                                    "Table 1 rows need it");
  run.pm = optionalField<bool>(json, "pm", false, inTable2, where,
                               "Table 2 rows need it");
  run.da = optionalField<std::string>(json, "da", "none", inTable2, where,
                                      "Table 2 rows need it");
  VLN_CHECK_ARG(
      std::find(kDaValues.begin(), kDaValues.end(), run.da) != kDaValues.end(),
      where, ": field 'da' must be one of ", joined(kDaValues), ", got '",
      run.da, "'");
  run.aug = optionalField<bool>(json, "aug", false, inTable2, where,
                                "Table 2 rows need it");
  return run;
}

// ---------------------------------------------------------------------------
// building
// ---------------------------------------------------------------------------

const TableRow* BuiltTable::findRow(std::string_view key) const {
  for (const auto& row : rows)
    if (row.paper->key == key) return &row;
  return nullptr;
}

std::vector<BuiltTable> buildTables(const std::filesystem::path& runsDir) {
  VLN_CHECK_IO(std::filesystem::is_directory(runsDir),
               "buildTables(): results directory '", runsDir.string(),
               "' does not exist or is not a directory");

  // runs at any depth (<experiment>/seed<S>/), in name order so the output
  // does not depend on the file system
  std::vector<std::filesystem::path> dirs;
  for (const auto& entry :
       std::filesystem::recursive_directory_iterator(runsDir))
    if (entry.is_directory() &&
        std::filesystem::exists(entry.path() / "run.json"))
      dirs.push_back(entry.path());
  std::sort(dirs.begin(), dirs.end());
  std::vector<RunInfo> runs;
  for (const auto& dir : dirs) {
    runs.push_back(readRunInfo(dir));
    runs.back().name = dir.lexically_relative(runsDir).generic_string();
  }

  // which runs claim which row: one per seed
  std::map<std::pair<int, std::string>, std::vector<const RunInfo*>> claims;
  for (const auto& run : runs) {
    for (const auto& claim : run.rows) {
      auto& claimants = claims[claim];
      for (const RunInfo* other : claimants)
        VLN_CHECK_ARG(other->seed != run.seed, "buildTables(): table ",
                      claim.first, " row '", claim.second,
                      "' is claimed by both '",
                      (other->dir / "run.json").string(), "' and '",
                      (run.dir / "run.json").string(), "' with seed ", run.seed,
                      " (the runs of one row need distinct seeds)");
      claimants.push_back(&run);
    }
  }

  std::vector<BuiltTable> tables;
  for (int number = 1; number <= 3; ++number) {
    BuiltTable built;
    built.paper = &paperTable(number);
    for (const auto& paperRow : built.paper->rows) {
      TableRow row;
      row.paper = &paperRow;
      auto it = claims.find({number, paperRow.key});
      if (it != claims.end()) {
        std::vector<const RunInfo*> claimants = it->second;
        std::sort(claimants.begin(), claimants.end(),
                  [](const RunInfo* a, const RunInfo* b) {
                    return a->seed < b->seed;
                  });
        OurRow ours;
        ours.model = claimants.front()->model;
        ours.attributes = runAttributes(*claimants.front(), number);
        for (const RunInfo* run : claimants) {
          // seeds of one row differ in the seed only: a row whose runs
          // disagree would average different experiments
          VLN_CHECK_ARG(run->model == ours.model &&
                            runAttributes(*run, number) == ours.attributes,
                        "buildTables(): the runs of table ", number, " row '",
                        paperRow.key,
                        "' disagree on the model or its attributes: '",
                        (claimants.front()->dir / "run.json").string(),
                        "' and '", (run->dir / "run.json").string(), "'");
          SeedRun seed;
          seed.run = run->name;
          seed.seed = run->seed;
          seed.checkpoint = run->checkpoint;
          seed.config = run->config;
          seed.command = run->command;
          for (const auto& split : built.paper->splits)
            seed.splits.push_back(splitValues(*run, *built.paper, split));
          ours.seeds.push_back(std::move(seed));
        }
        aggregateSeeds(*built.paper, ours);
        row.ours = std::move(ours);
      }
      built.rows.push_back(std::move(row));
    }
    tables.push_back(std::move(built));
  }
  return tables;
}

std::vector<BuiltTable> claimedRowsOnly(std::vector<BuiltTable> tables) {
  std::vector<BuiltTable> kept;
  for (auto& table : tables) {
    std::erase_if(table.rows, [](const TableRow& row) { return !row.ours; });
    if (!table.rows.empty()) kept.push_back(std::move(table));
  }
  return kept;
}

// ---------------------------------------------------------------------------
// rendering
// ---------------------------------------------------------------------------

std::string renderMarkdown(const BuiltTable& table) {
  const PaperTable& paper = *table.paper;
  std::ostringstream out;
  out << "### Table " << paper.number << ": " << paper.caption << "\n\n";

  // header
  out << "|" << (numbered(paper) ? " # |" : "") << " Model |";
  for (const auto& column : paper.attribute_columns)
    out << " " << column << " |";
  out << " Source | n |";
  for (const auto& split : paper.splits)
    for (const auto& metric : paper.metrics)
      out << " " << splitTitle(split) << " " << metric
          << (lowerIsBetter(metric) ? " ↓" : " ↑") << " |";
  out << "\n|" << (numbered(paper) ? " --: |" : "") << " :-- |";
  for (size_t i = 0; i < paper.attribute_columns.size(); ++i) out << " :-: |";
  out << " :-- | --: |";
  for (size_t i = 0; i < paper.splits.size() * paper.metrics.size(); ++i)
    out << " --: |";
  out << "\n";

  // rows: the paper's, then ours
  std::vector<const OurRow*> cited;
  for (const auto& row : table.rows) {
    const PaperRow& p = *row.paper;
    out << "|" << (numbered(paper) ? " " + p.key + " |" : "") << " " << p.model
        << " |";
    for (const auto& token : p.attributes) out << " " << mdToken(token) << " |";
    out << " paper | " << kNone << " |";
    for (const auto& split : p.values)
      for (const auto& value : split) out << " " << value << " |";
    out << "\n";
    if (!p.reproducible) continue;
    out << "|" << (numbered(paper) ? " " + p.key + " |" : "") << " ";
    if (!row.ours) {
      out << "*ours* |";
      for (size_t i = 0; i < paper.attribute_columns.size(); ++i) out << " |";
      out << " missing (no run) | 0 |";
      for (size_t i = 0; i < paper.splits.size() * paper.metrics.size(); ++i)
        out << " missing |";
      out << "\n";
      continue;
    }
    const OurRow& ours = *row.ours;
    cited.push_back(&ours);
    out << "*ours: " << ours.model << "* |";
    for (const auto& token : ours.attributes)
      out << " " << mdToken(token) << " |";
    out << " " << mdCode(sourceName(ours)) << " [" << cited.size() << "] | "
        << seedCount(ours, paper) << " |";
    for (size_t s = 0; s < paper.splits.size(); ++s)
      for (size_t m = 0; m < paper.metrics.size(); ++m)
        out << " " << formatCell(ours, s, m, kMdPlusMinus) << " |";
    out << "\n";
  }

  // references
  if (!cited.empty()) out << "\n";
  for (size_t i = 0; i < cited.size(); ++i)
    out << "[" << i + 1 << "] " << reference(*cited[i], paper, identity, mdCode)
        << "\n";
  return out.str();
}

std::string renderLatex(const BuiltTable& table) {
  const PaperTable& paper = *table.paper;
  // leading columns: number, model, attributes, source, n
  const size_t lead =
      (numbered(paper) ? 1 : 0) + 1 + paper.attribute_columns.size() + 2;
  const size_t nm = paper.metrics.size();
  std::ostringstream out;
  out << "% Table " << paper.number
      << " of Krantz et al. (2020) beside our runs\n"
      << "\\begin{table}[t]\n\\centering\\scriptsize\n"
      << "\\caption{Table " << paper.number
      << " (reproduction): " << texEscape(paper.caption) << "}\n";

  // column layout and headers
  out << "\\begin{tabular}{" << (numbered(paper) ? "r" : "") << "l";
  for (size_t i = 0; i < paper.attribute_columns.size(); ++i) out << "c";
  out << "lr";
  for (size_t s = 0; s < paper.splits.size(); ++s) out << std::string(nm, 'c');
  out << "}\n\\toprule\n";
  out << std::string(lead - 1, '&');
  for (const auto& split : paper.splits)
    out << " & \\multicolumn{" << nm << "}{c}{" << splitTitle(split) << "}";
  out << " \\\\\n";
  for (size_t s = 0; s < paper.splits.size(); ++s)
    out << "\\cmidrule(lr){" << lead + 1 + s * nm << "-" << lead + (s + 1) * nm
        << "}";
  out << "\n" << (numbered(paper) ? "\\# & " : "") << "Model";
  for (const auto& column : paper.attribute_columns)
    out << " & " << texEscape(column);
  out << " & Source & $n$";
  for (size_t s = 0; s < paper.splits.size(); ++s)
    for (const auto& metric : paper.metrics)
      out << " & " << texEscape(metric)
          << (lowerIsBetter(metric) ? "$\\downarrow$" : "$\\uparrow$");
  out << " \\\\\n\\midrule\n";

  // rows
  std::vector<const OurRow*> cited;
  for (const auto& row : table.rows) {
    const PaperRow& p = *row.paper;
    const std::string number = numbered(paper) ? texEscape(p.key) + " & " : "";
    out << number << texEscape(p.model);
    for (const auto& token : p.attributes) out << " & " << texToken(token);
    out << " & paper & " << kNone;
    for (const auto& split : p.values)
      for (const auto& value : split) out << " & " << texEscape(value);
    out << " \\\\\n";
    if (!p.reproducible) continue;
    out << number << "\\quad\\textit{ours}";
    if (!row.ours) {
      for (size_t i = 0; i < paper.attribute_columns.size(); ++i) out << " & ";
      out << " & missing & 0";
      for (size_t i = 0; i < paper.splits.size() * nm; ++i) out << " & missing";
      out << " \\\\\n";
      continue;
    }
    const OurRow& ours = *row.ours;
    cited.push_back(&ours);
    for (const auto& token : ours.attributes) out << " & " << texToken(token);
    out << " & [" << cited.size() << "] & "
        << texEscape(seedCount(ours, paper));
    for (size_t s = 0; s < paper.splits.size(); ++s)
      for (size_t m = 0; m < nm; ++m)
        out << " & " << formatCell(ours, s, m, kTexPlusMinus);
    out << " \\\\\n";
  }
  out << "\\bottomrule\n\\end{tabular}\n";

  // references
  if (!cited.empty()) {
    out << "\\par\\raggedright\n";
    for (size_t i = 0; i < cited.size(); ++i)
      out << "[" << i + 1 << "] "
          << reference(*cited[i], paper, texEscape, texCode) << "\\\\\n";
  }
  out << "\\end{table}\n";
  return out.str();
}

std::pair<std::filesystem::path, std::filesystem::path> writeTables(
    const std::vector<BuiltTable>& tables,
    const std::filesystem::path& markdownFile, const std::string& generatedBy) {
  std::filesystem::path texFile = markdownFile;
  texFile.replace_extension(".tex");
  VLN_CHECK_ARG(texFile != markdownFile, "writeTables(): '",
                markdownFile.string(),
                "' must not end in .tex (the LaTeX goes beside the Markdown)");
  std::string markdown = "<!-- Generated by `" + generatedBy +
                         "`; numbers marked ours come from the result files "
                         "they cite. -->\n\n";
  std::string latex =
      "% Generated by `" + generatedBy + "`; needs booktabs and amssymb.\n\n";
  if (tables.empty()) {
    markdown += "No run claims a row of the paper's tables.\n";
    latex += "% No run claims a row of the paper's tables.\n";
  }
  for (const auto& table : tables) {
    markdown += renderMarkdown(table) + "\n";
    latex += renderLatex(table) + "\n";
  }
  common::writeFileAtomic(markdownFile, markdown);
  common::writeFileAtomic(texFile, latex);
  return {markdownFile, texFile};
}

}  // namespace vln::eval
