#pragma once
// RxR_VLNCE_v0 episodes (RxR-Habitat), as VLN-CE's RxRVLNCEDatasetV1 reads
// them. Per split and annotation role (guide, follower):
//   <data_path>/{split}/{split}_{role}.json.gz     {"episodes": [...]}
//   <data_path>/{split}/{split}_{role}_gt.json.gz  ground truth (GroundTruth.h)
// Episodes have R2R_VLNCE's fields (Episode.h) without instruction_tokens and
// instruction_vocab, and in `instruction`: instruction_id, language
// ("en-US", "en-IN", "hi-IN", "te-IN"), annotator_id, edit_distance and
// timed_instruction [{word, start_time, end_time}, ...] (times in seconds,
// NaN or absent for some words). test_challenge has no ground truth.
//
// Like VLN-CE, the reader loads the chosen roles, then keeps the chosen
// languages, then the allowed episode ids; "*" in a list means all.

#include <array>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "common/Config.h"
#include "data/Episode.h"
#include "data/GroundTruth.h"

namespace vln::data {

/// "Everything" in the role, language and episode lists.
inline constexpr std::string_view kRxrAll = "*";
/// RxR's annotation roles, in VLN-CE's order.
inline constexpr std::array<std::string_view, 2> kRxrRoles = {"guide",
                                                              "follower"};
/// RxR's languages.
inline constexpr std::array<std::string_view, 4> kRxrLanguages = {
    "en-US", "en-IN", "hi-IN", "te-IN"};

/// Which RxR episodes to load (VLN-CE's DATASET.ROLES, LANGUAGES and
/// EPISODES_ALLOWED). YAML keys equal member names.
struct RxrFilterConfig {
  std::vector<std::string> roles = {"guide"};
  std::vector<std::string> languages = {"*"};
  std::vector<std::string> episodes_allowed = {"*"};

  void visit(common::ConfigVisitor& v) {
    v.field("roles", roles,
            "Annotation roles to load: guide, follower or * (both)");
    v.field("languages", languages,
            "Instruction languages to keep: en-US, en-IN, hi-IN, te-IN or * "
            "(all)");
    v.field("episodes_allowed", episodes_allowed,
            "Episode ids to keep (decimal strings), or * (all)");
  }
  /// Throws std::invalid_argument naming the key for an unknown role or
  /// language, a non-decimal episode id or an empty list.
  void validate() const;
  /// The roles to read, in kRxrRoles order when "*".
  std::vector<std::string> resolvedRoles() const;
  bool operator==(const RxrFilterConfig&) const = default;
};

/// `root / split / (split + "_" + role + ".json.gz")`.
std::filesystem::path rxrEpisodesPath(const std::filesystem::path& root,
                                      std::string_view split,
                                      std::string_view role);

/// `root / split / (split + "_" + role + "_gt.json.gz")`.
std::filesystem::path rxrGroundTruthPath(const std::filesystem::path& root,
                                         std::string_view split,
                                         std::string_view role);

/// Reads one RxR episode file (.json or .json.gz) with readEpisodes()'s
/// checks plus: every episode has instruction.instruction_id and
/// instruction.language. Throws std::invalid_argument naming the file, the
/// episode and the field.
std::vector<Episode> readRxrEpisodeFile(const std::filesystem::path& file);

/// The episodes of `split` under `root` for `filter`: the roles' files in
/// order, then the language and episode filters. Throws
/// std::invalid_argument for an invalid filter or an episode id found in
/// two role files, std::runtime_error for a missing file (naming it).
std::vector<Episode> readRxrEpisodes(const std::filesystem::path& root,
                                     std::string_view split,
                                     const RxrFilterConfig& filter);

/// Keeps the episodes whose language and id `filter` allows (file order).
void filterRxrEpisodes(std::vector<Episode>& episodes,
                       const RxrFilterConfig& filter);

/// The ground truth of `split` for `roles` (the files merged, as VLN-CE's
/// NDTW measure and recollect trainer do). Throws std::invalid_argument
/// when an episode id appears in two role files.
GroundTruth readRxrGroundTruth(const std::filesystem::path& root,
                               std::string_view split,
                               const std::vector<std::string>& roles);

}  // namespace vln::data
