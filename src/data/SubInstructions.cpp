#include "data/SubInstructions.h"

#include <algorithm>
#include <cctype>
#include <limits>

#include "common/Check.h"
#include "common/Json.h"
#include "data/Vocabulary.h"

namespace vln::data {
namespace {

// intField() of a JSON object, at least 0
int nonNegativeInt(const nlohmann::json& object, const char* key,
                   std::string_view context) {
  VLN_CHECK_ARG(object.is_object(), context, ": expected a JSON object, got ",
                object.type_name());
  const int value = intField(object, key, context);
  VLN_CHECK_ARG(value >= 0, context, ": field '", key, "' must be in [0, ",
                std::numeric_limits<int>::max(), "], got ", value);
  return value;
}

void validate(const SubInstruction& s, std::string_view context) {
  VLN_CHECK_ARG(s.begin >= 0 && s.leg >= 0, context,
                ": fields 'begin' and 'leg' must be >= 0, got ", s.begin,
                " and ", s.leg);
  VLN_CHECK_ARG(s.end >= s.begin, context, ": field 'end' (", s.end,
                ") is before 'begin' (", s.begin, ")");
}

}  // namespace

std::filesystem::path splitSubInstructionsPath(
    const std::filesystem::path& root, std::string_view split) {
  return root / split / (std::string(split) + "_sub_instructions.json.gz");
}

SubInstructions readSubInstructions(const std::filesystem::path& file) {
  const std::string where =
      strCat("readSubInstructions(): '", file.string(), "'");
  const nlohmann::json root = common::readJsonFile(file);
  VLN_CHECK_ARG(root.is_object(), where,
                ": expected a JSON object keyed by episode id, got ",
                root.type_name());
  SubInstructions out;
  for (const auto& [key, entry] : root.items()) {
    const int id = episodeIdKey(key, where);
    const std::string context = strCat(where, ": episode ", id);
    VLN_CHECK_ARG(entry.is_array(), context,
                  ": expected an array of sub-instructions, got ",
                  entry.type_name());
    std::vector<SubInstruction> list;
    for (size_t i = 0; i < entry.size(); ++i) {
      const std::string item = strCat(context, ": sub-instruction ", i);
      SubInstruction s;
      s.begin = nonNegativeInt(entry[i], "begin", item);
      s.end = nonNegativeInt(entry[i], "end", item);
      s.leg = nonNegativeInt(entry[i], "leg", item);
      validate(s, item);
      list.push_back(s);
    }
    VLN_CHECK_ARG(out.emplace(id, std::move(list)).second, where,
                  ": episode id ", id, " appears twice (key '", key, "')");
  }
  return out;
}

void writeSubInstructions(const std::filesystem::path& file,
                          const SubInstructions& subInstructions) {
  const std::string where =
      strCat("writeSubInstructions(): '", file.string(), "'");
  nlohmann::json root = nlohmann::json::object();
  for (const auto& [id, list] : subInstructions) {
    nlohmann::json entries = nlohmann::json::array();
    for (size_t i = 0; i < list.size(); ++i) {
      validate(list[i],
               strCat(where, ": episode ", id, ": sub-instruction ", i));
      entries.push_back({{"begin", list[i].begin},
                         {"end", list[i].end},
                         {"leg", list[i].leg}});
    }
    root[std::to_string(id)] = std::move(entries);
  }
  common::writeJsonFile(file, root);
}

void checkSubInstructions(const SubInstructions& subInstructions,
                          const std::vector<Episode>& episodes,
                          std::string_view source) {
  for (const Episode& e : episodes) {
    auto it = subInstructions.find(e.episode_id);
    VLN_CHECK_ARG(it != subInstructions.end(), source, ": episode ",
                  e.episode_id, " has no sub-instructions");
    const auto textSize =
        static_cast<int64_t>(e.instruction.instruction_text.size());
    const auto stopLeg = static_cast<int64_t>(e.reference_path.size()) - 1;
    for (size_t i = 0; i < it->second.size(); ++i) {
      const SubInstruction& s = it->second[i];
      VLN_CHECK_ARG(s.end <= textSize, source, ": episode ", e.episode_id,
                    ": sub-instruction ", i, ": field 'end' (", s.end,
                    ") is beyond the instruction_text's ", textSize, " bytes");
      VLN_CHECK_ARG(s.leg <= stopLeg, source, ": episode ", e.episode_id,
                    ": sub-instruction ", i, ": field 'leg' (", s.leg,
                    ") is beyond the reference_path's last point (", stopLeg,
                    ")");
    }
  }
}

std::vector<SubInstructionTokens> subInstructionTokens(
    std::string_view text, const std::vector<SubInstruction>& subInstructions) {
  auto tokensBefore = [&](int offset) {
    const size_t n =
        std::min(static_cast<size_t>(std::max(offset, 0)), text.size());
    return static_cast<int>(tokenize(text.substr(0, n)).size());
  };
  std::vector<SubInstructionTokens> out;
  out.reserve(subInstructions.size());
  for (const SubInstruction& s : subInstructions)
    out.push_back({tokensBefore(s.begin), tokensBefore(s.end), s.leg});
  return out;
}

std::vector<SubInstructionTokens> ruleClauses(std::string_view text) {
  auto isWord = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '\'' ||
           c == '-' || c == '_';
  };
  // the word starting at byte i (lower case), empty unless i starts one
  auto wordAt = [&](size_t i) {
    if (i >= text.size() || !isWord(text[i]) || (i > 0 && isWord(text[i - 1])))
      return std::string();
    std::string word;
    while (i < text.size() && isWord(text[i]))
      word.push_back(static_cast<char>(
          std::tolower(static_cast<unsigned char>(text[i++]))));
    return word;
  };
  std::vector<size_t> cuts{0};
  std::string previousWord;
  for (size_t i = 0; i < text.size(); ++i) {
    if (std::string_view(".,;:!?").find(text[i]) != std::string_view::npos) {
      cuts.push_back(i + 1);
      previousWord.clear();
      continue;
    }
    const std::string word = wordAt(i);
    if (word.empty()) continue;
    if (word == "and" || (word == "then" && previousWord != "and"))
      cuts.push_back(i);
    previousWord = word;
  }
  cuts.push_back(text.size());
  // byte cuts -> token boundaries, one piece at a time so that a long text
  // with many cuts costs its length, not its length times its cuts: a cut
  // after punctuation moves on to the next word, so that every cut starts
  // a word and each piece ends where tokenize() ends a run of non-word
  // characters (the pieces' tokens are the text's)
  for (size_t& cut : cuts)
    while (cut < text.size() && !isWord(text[cut])) ++cut;
  std::sort(cuts.begin(), cuts.end());
  cuts.erase(std::unique(cuts.begin(), cuts.end()), cuts.end());
  std::vector<int> bounds{0};
  for (size_t k = 1; k < cuts.size(); ++k)
    bounds.push_back(
        bounds.back() +
        static_cast<int>(
            tokenize(text.substr(cuts[k - 1], cuts[k] - cuts[k - 1])).size()));
  std::vector<SubInstructionTokens> out;
  for (size_t k = 0; k + 1 < bounds.size(); ++k)
    if (bounds[k + 1] > bounds[k])
      out.push_back({bounds[k], bounds[k + 1], static_cast<int>(out.size())});
  return out;
}

int clauseHolding(const std::vector<SubInstructionTokens>& clauses, int token) {
  int holding = 0;
  for (size_t k = 0; k < clauses.size(); ++k)
    if (clauses[k].first <= token) holding = static_cast<int>(k);
  return holding;
}

int upcomingLeg(const std::vector<Vec3f>& path, const Vec3f& position,
                float lookahead) {
  VLN_CHECK_ARG(path.size() >= 2,
                "upcomingLeg(): a path needs two points, got ", path.size());
  // the nearest point of the path, as a distance along it
  float best = std::numeric_limits<float>::infinity();
  float along = 0.0f, start = 0.0f;
  std::vector<float> legStart{0.0f};
  for (size_t i = 0; i + 1 < path.size(); ++i) {
    const Vec3f d = path[i + 1] - path[i];
    const float length = d.norm();
    const float t =
        length > 0.0f
            ? std::clamp((position - path[i]).dot(d) / (length * length), 0.0f,
                         1.0f)
            : 0.0f;
    const float distance = (path[i] + t * d - position).norm();
    if (distance < best) {
      best = distance;
      along = start + t * length;
    }
    start += length;
    legStart.push_back(start);
  }
  const float ahead = along + lookahead;
  if (ahead >= start) return static_cast<int>(path.size()) - 1;
  // the last leg starting at or before `ahead`
  const auto it = std::upper_bound(legStart.begin(), legStart.end(), ahead);
  return static_cast<int>(it - legStart.begin()) - 1;
}

std::vector<SubInstructionTokens> clausesAhead(
    const std::vector<SubInstructionTokens>& clauses,
    const std::vector<Vec3f>& path, const Vec3f& position) {
  if (path.size() < 2) return {};
  const int leg = upcomingLeg(path, position, kLegLookahead);
  int target = std::numeric_limits<int>::max();
  for (const SubInstructionTokens& c : clauses)
    if (c.leg >= leg) target = std::min(target, c.leg);
  std::vector<SubInstructionTokens> out;
  for (const SubInstructionTokens& c : clauses)
    if (c.leg == target) out.push_back(c);
  return out;
}

}  // namespace vln::data
