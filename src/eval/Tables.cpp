#include "eval/Tables.h"

#include <algorithm>
#include <cstdio>
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
    "model",       "rows",    "checkpoint", "config", "command", "vision",
    "instruction", "history", "pm",         "da",     "aug",     "notes"};
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
std::optional<std::vector<double>> splitValues(const RunInfo& run,
                                               const PaperTable& table,
                                               const std::string& split,
                                               int* numEpisodes) {
  nlohmann::json stats;
  if (table.number == 3) {
    const auto file = run.dir / graphStatsFileName(run.checkpoint, split);
    if (!std::filesystem::exists(file)) return std::nullopt;
    const GraphSplitStats s = readGraphStatsFile(file);
    stats = graphStatsToJson(s);
    *numEpisodes = s.num_episodes;
  } else {
    const auto file = run.dir / rollout::statsFileName(run.checkpoint, split);
    if (!std::filesystem::exists(file)) return std::nullopt;
    const rollout::SplitStats s = rollout::readStatsFile(file);
    stats = rollout::statsToJson(s);
    *numEpisodes = s.num_episodes;
  }
  std::vector<double> values;
  for (const auto& metric : table.metrics)
    values.push_back(
        stats.at(std::string(metricStatsKey(metric))).get<double>());
  return values;
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

std::string reference(const OurRow& ours, const PaperTable& table) {
  std::string episodes;
  for (size_t s = 0; s < table.splits.size(); ++s)
    episodes += strCat(s ? ", " : "", table.splits[s], " ",
                       ours.values[s] ? std::to_string(ours.num_episodes[s])
                                      : std::string("missing"));
  return strCat("run ", ours.run, ", checkpoint ", ours.checkpoint,
                ", episodes ", episodes);
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

std::vector<BuiltTable> buildTables(const std::filesystem::path& runsDir) {
  VLN_CHECK_IO(std::filesystem::is_directory(runsDir),
               "buildTables(): results directory '", runsDir.string(),
               "' does not exist or is not a directory");

  // runs in name order so the output does not depend on the file system
  std::vector<std::filesystem::path> dirs;
  for (const auto& entry : std::filesystem::directory_iterator(runsDir))
    if (entry.is_directory() &&
        std::filesystem::exists(entry.path() / "run.json"))
      dirs.push_back(entry.path());
  std::sort(dirs.begin(), dirs.end());
  std::vector<RunInfo> runs;
  for (const auto& dir : dirs) runs.push_back(readRunInfo(dir));

  // which run claims which row
  std::map<std::pair<int, std::string>, const RunInfo*> claims;
  for (const auto& run : runs) {
    for (const auto& claim : run.rows) {
      auto [it, inserted] = claims.emplace(claim, &run);
      VLN_CHECK_ARG(inserted, "buildTables(): table ", claim.first, " row '",
                    claim.second, "' is claimed by both '",
                    (it->second->dir / "run.json").string(), "' and '",
                    (run.dir / "run.json").string(), "'");
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
        const RunInfo& run = *it->second;
        OurRow ours;
        ours.run = run.name;
        ours.model = run.model;
        ours.attributes = runAttributes(run, number);
        ours.checkpoint = run.checkpoint;
        ours.config = run.config;
        ours.command = run.command;
        for (const auto& split : built.paper->splits) {
          int episodes = 0;
          ours.values.push_back(
              splitValues(run, *built.paper, split, &episodes));
          ours.num_episodes.push_back(episodes);
        }
        row.ours = std::move(ours);
      }
      built.rows.push_back(std::move(row));
    }
    tables.push_back(std::move(built));
  }
  return tables;
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
  out << " Source |";
  for (const auto& split : paper.splits)
    for (const auto& metric : paper.metrics)
      out << " " << splitTitle(split) << " " << metric
          << (lowerIsBetter(metric) ? " ↓" : " ↑") << " |";
  out << "\n|" << (numbered(paper) ? " --: |" : "") << " :-- |";
  for (size_t i = 0; i < paper.attribute_columns.size(); ++i) out << " :-: |";
  out << " :-- |";
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
    out << " paper |";
    for (const auto& split : p.values)
      for (const auto& value : split) out << " " << value << " |";
    out << "\n";
    if (!p.reproducible) continue;
    out << "|" << (numbered(paper) ? " " + p.key + " |" : "") << " ";
    if (!row.ours) {
      out << "*ours* |";
      for (size_t i = 0; i < paper.attribute_columns.size(); ++i) out << " |";
      out << " missing (no run) |";
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
    out << " " << mdCode(ours.run) << " [" << cited.size() << "] |";
    for (const auto& split : ours.values)
      for (size_t m = 0; m < paper.metrics.size(); ++m)
        out << " " << (split ? formatValue((*split)[m]) : "missing") << " |";
    out << "\n";
  }

  // references
  if (!cited.empty()) out << "\n";
  for (size_t i = 0; i < cited.size(); ++i)
    out << "[" << i + 1 << "] " << reference(*cited[i], paper) << "; config "
        << mdCode(cited[i]->config) << "; command " << mdCode(cited[i]->command)
        << "\n";
  return out.str();
}

std::string renderLatex(const BuiltTable& table) {
  const PaperTable& paper = *table.paper;
  const size_t lead =
      (numbered(paper) ? 1 : 0) + 1 + paper.attribute_columns.size() + 1;
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
  out << "l";
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
  out << " & Source";
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
    out << " & paper";
    for (const auto& split : p.values)
      for (const auto& value : split) out << " & " << texEscape(value);
    out << " \\\\\n";
    if (!p.reproducible) continue;
    out << number << "\\quad\\textit{ours}";
    if (!row.ours) {
      for (size_t i = 0; i < paper.attribute_columns.size(); ++i) out << " & ";
      out << " & missing";
      for (size_t i = 0; i < paper.splits.size() * nm; ++i) out << " & missing";
      out << " \\\\\n";
      continue;
    }
    const OurRow& ours = *row.ours;
    cited.push_back(&ours);
    for (const auto& token : ours.attributes) out << " & " << texToken(token);
    out << " & [" << cited.size() << "]";
    for (const auto& split : ours.values)
      for (size_t m = 0; m < nm; ++m)
        out << " & " << (split ? formatValue((*split)[m]) : "missing");
    out << " \\\\\n";
  }
  out << "\\bottomrule\n\\end{tabular}\n";

  // references
  if (!cited.empty()) {
    out << "\\par\\raggedright\n";
    for (size_t i = 0; i < cited.size(); ++i)
      out << "[" << i + 1 << "] " << texEscape(reference(*cited[i], paper))
          << "; config \\texttt{" << texEscape(cited[i]->config)
          << "}; command \\texttt{" << texEscape(cited[i]->command)
          << "}\\\\\n";
  }
  out << "\\end{table}\n";
  return out.str();
}

std::pair<std::filesystem::path, std::filesystem::path> writeTables(
    const std::vector<BuiltTable>& tables,
    const std::filesystem::path& outDir) {
  std::string markdown =
      "<!-- Generated by vln::eval::writeTables(); numbers marked ours come "
      "from the result files they cite. -->\n\n";
  std::string latex =
      "% Generated by vln::eval::writeTables(); needs booktabs and "
      "amssymb.\n\n";
  for (const auto& table : tables) {
    markdown += renderMarkdown(table) + "\n";
    latex += renderLatex(table) + "\n";
  }
  const auto md = outDir / "tables.md";
  const auto tex = outDir / "tables.tex";
  common::writeFileAtomic(md, markdown);
  common::writeFileAtomic(tex, latex);
  return {md, tex};
}

}  // namespace vln::eval
