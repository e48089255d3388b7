#include "data/RxrEpisodes.h"

#include <algorithm>
#include <charconv>
#include <set>
#include <unordered_set>

#include "common/Check.h"

namespace vln::data {
namespace {

bool containsAll(const std::vector<std::string>& list) {
  return std::find(list.begin(), list.end(), kRxrAll) != list.end();
}

template <size_t N>
bool isOneOf(const std::string& value,
             const std::array<std::string_view, N>& known) {
  return std::find(known.begin(), known.end(), value) != known.end();
}

// a decimal episode id of episodes_allowed
int allowedId(const std::string& text) {
  int id = 0;
  auto [end, error] =
      std::from_chars(text.data(), text.data() + text.size(), id);
  VLN_CHECK_ARG(
      !text.empty() && error == std::errc() && end == text.data() + text.size(),
      "RxrFilterConfig: episodes_allowed: '", text,
      "' is neither * nor a decimal episode id");
  return id;
}

}  // namespace

// =========================================================================
// the filter
// =========================================================================

void RxrFilterConfig::validate() const {
  VLN_CHECK_ARG(!roles.empty(), "RxrFilterConfig: roles is empty (use *)");
  for (const std::string& role : roles)
    VLN_CHECK_ARG(role == kRxrAll || isOneOf(role, kRxrRoles),
                  "RxrFilterConfig: roles: unknown role '", role,
                  "' (guide, follower or *)");
  VLN_CHECK_ARG(!languages.empty(),
                "RxrFilterConfig: languages is empty (use *)");
  for (const std::string& language : languages)
    VLN_CHECK_ARG(language == kRxrAll || isOneOf(language, kRxrLanguages),
                  "RxrFilterConfig: languages: unknown language '", language,
                  "' (en-US, en-IN, hi-IN, te-IN or *)");
  VLN_CHECK_ARG(!episodes_allowed.empty(),
                "RxrFilterConfig: episodes_allowed is empty (use *)");
  for (const std::string& id : episodes_allowed)
    if (id != kRxrAll) allowedId(id);
}

std::vector<std::string> RxrFilterConfig::resolvedRoles() const {
  if (containsAll(roles)) return {kRxrRoles.begin(), kRxrRoles.end()};
  return roles;
}

// =========================================================================
// paths
// =========================================================================

std::filesystem::path rxrEpisodesPath(const std::filesystem::path& root,
                                      std::string_view split,
                                      std::string_view role) {
  return root / split / strCat(split, "_", role, ".json.gz");
}

std::filesystem::path rxrGroundTruthPath(const std::filesystem::path& root,
                                         std::string_view split,
                                         std::string_view role) {
  return root / split / strCat(split, "_", role, "_gt.json.gz");
}

// =========================================================================
// reading
// =========================================================================

std::vector<Episode> readRxrEpisodeFile(const std::filesystem::path& file) {
  EpisodeDataset dataset = readEpisodes(file);
  // the fields that name the features and the inference output
  for (const Episode& episode : dataset.episodes) {
    const std::string context = strCat("readRxrEpisodeFile(): '", file.string(),
                                       "': episode ", episode.episode_id);
    VLN_CHECK_ARG(episode.instruction.instruction_id.has_value(), context,
                  ": field 'instruction.instruction_id' is missing (not an "
                  "RxR_VLNCE episode?)");
    VLN_CHECK_ARG(!episode.instruction.language.empty(), context,
                  ": field 'instruction.language' is missing (not an "
                  "RxR_VLNCE episode?)");
  }
  return std::move(dataset.episodes);
}

void filterRxrEpisodes(std::vector<Episode>& episodes,
                       const RxrFilterConfig& filter) {
  filter.validate();
  if (!containsAll(filter.languages)) {
    const std::set<std::string> keep(filter.languages.begin(),
                                     filter.languages.end());
    std::erase_if(episodes, [&](const Episode& e) {
      return !keep.contains(e.instruction.language);
    });
  }
  if (!containsAll(filter.episodes_allowed)) {
    std::unordered_set<int> keep;
    for (const std::string& id : filter.episodes_allowed)
      keep.insert(allowedId(id));
    std::erase_if(episodes, [&](const Episode& e) {
      return !keep.contains(e.episode_id);
    });
  }
}

std::vector<Episode> readRxrEpisodes(const std::filesystem::path& root,
                                     std::string_view split,
                                     const RxrFilterConfig& filter) {
  filter.validate();
  std::vector<Episode> episodes;
  std::unordered_set<int> seen;
  for (const std::string& role : filter.resolvedRoles()) {
    const std::filesystem::path file = rxrEpisodesPath(root, split, role);
    for (Episode& episode : readRxrEpisodeFile(file)) {
      // ground truth is keyed by episode id across roles: ids must be unique
      VLN_CHECK_ARG(seen.insert(episode.episode_id).second,
                    "readRxrEpisodes(): '", file.string(), "': episode ",
                    episode.episode_id,
                    ": field 'episode_id' also appears in an earlier role's "
                    "file");
      episodes.push_back(std::move(episode));
    }
  }
  filterRxrEpisodes(episodes, filter);
  return episodes;
}

GroundTruth readRxrGroundTruth(const std::filesystem::path& root,
                               std::string_view split,
                               const std::vector<std::string>& roles) {
  GroundTruth merged;
  for (const std::string& role : roles) {
    VLN_CHECK_ARG(isOneOf(role, kRxrRoles), "readRxrGroundTruth(): role '",
                  role, "' is not guide or follower");
    const std::filesystem::path file = rxrGroundTruthPath(root, split, role);
    for (auto& [id, path] : readGroundTruth(file))
      VLN_CHECK_ARG(merged.emplace(id, std::move(path)).second,
                    "readRxrGroundTruth(): '", file.string(), "': episode ", id,
                    " also appears in an earlier role's file");
  }
  return merged;
}

}  // namespace vln::data
