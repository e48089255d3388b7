#pragma once
// VLN-CE episodes in the public R2R_VLNCE_v1-3(_preprocessed) layout:
// `{split}/{split}.json.gz` = {"episodes": [...], "instruction_vocab": {...}}
// with, per episode,
//   episode_id (int), trajectory_id (int), scene_id ("mp3d/<scan>/<scan>.glb"),
//   start_position [x, y, z], start_rotation [x, y, z, w] (yaw-only, unit),
//   info {geodesic_distance}, goals [{position, radius}],
//   instruction {instruction_text, instruction_tokens}, reference_path
//   [[x, y, z], ...].
// The test split has no info, goals or reference_path; the non-preprocessed
// release has no instruction_tokens and no instruction_vocab. All positions
// are in Habitat's world frame (metres, +Y up; see common/Math.h).
//
// RxR_VLNCE_v0 episodes (data/RxrEpisodes.h) share this layout and add, in
// `instruction`, instruction_id, language, annotator_id, edit_distance and
// timed_instruction; they have no instruction_tokens. Those fields are
// optional here: absent in R2R files and then not written.

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "common/Math.h"
#include "data/Vocabulary.h"

namespace vln::data {

/// Goal radius of every R2R_VLNCE goal, metres.
inline constexpr float kDefaultGoalRadius = 3.0f;

/// A navigation goal: a world-frame point (metres) and a success radius.
struct Goal {
  Vec3f position = Vec3f::Zero();
  float radius = kDefaultGoalRadius;  ///< metres
  bool operator==(const Goal&) const = default;
};

/// One word of an RxR instruction with when the annotator spoke it, in
/// seconds from the start of the recording. Times are absent (nullopt) when
/// the file has no value, null or NaN for them.
struct TimedWord {
  std::string word;
  std::optional<double> start_time;  ///< seconds
  std::optional<double> end_time;    ///< seconds
  bool operator==(const TimedWord&) const = default;
};

/// The natural-language instruction of an episode.
struct Instruction {
  std::string instruction_text;
  /// Vocabulary indices right-padded with PAD_INDEX (0) to 200 entries in
  /// the public files; empty when the file stores no tokens.
  std::vector<int> instruction_tokens;

  // RxR_VLNCE_v0 only; absent in R2R files.
  /// RxR's instruction id (an integer, or a decimal string, in the file;
  /// written as a string, the type VLN-CE declares); it names the text
  /// feature file and the lines of the inference output.
  std::optional<int64_t> instruction_id;
  /// "en-US", "en-IN", "hi-IN" or "te-IN"; empty when absent.
  std::string language;
  /// The annotator (an integer or string in the file; written as a string).
  std::optional<std::string> annotator_id;
  /// RxR's edit distance of the annotation (a number in the file).
  std::optional<double> edit_distance;
  /// The instruction word by word with timestamps; empty when absent.
  std::vector<TimedWord> timed_instruction;

  bool operator==(const Instruction&) const = default;
};

/// One R2R_VLNCE (or RxR_VLNCE_v0) episode. Field names equal the JSON
/// keys. The ids are JSON integers, or strings holding decimal integers.
struct Episode {
  int episode_id = 0;
  int trajectory_id = 0;
  std::string scene_id;                  ///< "mp3d/<scan>/<scan>.glb"
  Vec3f start_position = Vec3f::Zero();  ///< world frame, metres
  std::array<float, 4> start_rotation = {0.0f, 0.0f, 0.0f,
                                         1.0f};  ///< [x,y,z,w]
  /// info.geodesic_distance (metres); absent in the test split.
  std::optional<float> geodesic_distance;
  /// Empty in the test split (and then not written).
  std::vector<Goal> goals;
  Instruction instruction;
  /// Path through the nav-graph nodes, world frame, metres; empty in the
  /// test split (and then not written).
  std::vector<Vec3f> reference_path;

  /// Start heading in radians (0 looks along -Z, counter-clockwise
  /// positive), from start_rotation.
  float startHeading() const { return quaternionToHeading(start_rotation); }
  bool operator==(const Episode&) const = default;
};

/// The contents of one episode file.
struct EpisodeDataset {
  std::vector<Episode> episodes;
  /// Absent in files without instruction tokens.
  std::optional<Vocabulary> instruction_vocab;
  bool operator==(const EpisodeDataset&) const = default;
};

/// Keeps at most `count` of `episodes`, spread evenly over the list
/// (indices floor(i * n / count), file order kept); all of them when
/// count < 0 or count >= n. R2R files list a scene's episodes together, so
/// the first N would cover only a few scenes.
void keepEvenlySpaced(std::vector<Episode>& episodes, int count);

/// Tolerance on |q| - 1 and on the x and z components of start_rotation.
inline constexpr float kQuaternionTolerance = 1e-4f;

/// Reads an episode file (.json or .json.gz). Throws std::runtime_error for
/// missing or truncated files and std::invalid_argument naming the file, the
/// episode id and the field for malformed JSON, missing fields, wrong types,
/// non-finite numbers, a start_rotation that is not a unit yaw-only
/// quaternion, instruction tokens outside [0, num_vocab), a non-positive
/// goal radius and duplicate episode ids.
EpisodeDataset readEpisodes(const std::filesystem::path& file);

/// Parses the root object of an episode file; `source` names it in errors.
EpisodeDataset parseEpisodes(const nlohmann::json& root,
                             std::string_view source);

/// Atomically writes `dataset` to `file` (gzip when it ends in .gz) in the
/// public layout. Validates first with the same rules as readEpisodes() and
/// throws std::invalid_argument (leaving no file) on an invalid episode.
void writeEpisodes(const std::filesystem::path& file,
                   const EpisodeDataset& dataset);

/// The root JSON object writeEpisodes() writes.
nlohmann::json episodesToJson(const EpisodeDataset& dataset);

/// One episode as a JSON object (optional parts omitted when absent).
nlohmann::json episodeToJson(const Episode& episode);

/// Parses one episode object (entry `index` of the file's "episodes").
/// Timestamps of timed_instruction may be null (NaN in the Python files:
/// readEpisodes() turns bare NaN / Infinity tokens into null first).
/// Errors start with `source` (e.g. "readEpisodes(): 'val_seen.json.gz'")
/// and name "episode <id>" and the field, or "episode index <index>" while
/// the id itself is missing or malformed.
Episode episodeFromJson(const nlohmann::json& value, std::string_view source,
                        size_t index = 0);

/// Checks the invariants listed at readEpisodes() (except duplicates);
/// `vocabulary`, when given, bounds the tokens. Throws
/// std::invalid_argument prefixed with `context` and naming the field.
void validateEpisode(const Episode& episode, const Vocabulary* vocabulary,
                     std::string_view context);

/// Reads a JSON [x, y, z] array of finite numbers (world frame, metres);
/// `context` names the field in errors.
Vec3f vec3FromJson(const nlohmann::json& value, std::string_view context);

/// [x, y, z] as a JSON array.
nlohmann::json vec3ToJson(const Vec3f& v);

/// The episode id an object key of a per-episode file spells ("12"), as the
/// ground-truth and sub-instruction files key their entries. Throws
/// std::invalid_argument "<context>: key '<key>' is not an integer episode
/// id" for anything else.
int episodeIdKey(std::string_view key, std::string_view context);

/// The required integer member `key` of a JSON object, checked (nlohmann's
/// get<int>() would truncate a float silently). Throws
/// std::invalid_argument "<context>: field '<key>' ..." when it is missing,
/// not an integer or outside int's range.
int intField(const nlohmann::json& object, std::string_view key,
             std::string_view context);

/// The scan name of a scene id: "mp3d/<scan>/<scan>.glb" -> "<scan>".
std::string sceneScanId(std::string_view sceneId);

/// `scenesDir / sceneId` (or `sceneId` itself when absolute). Throws
/// std::runtime_error naming the scene id, the scenes directory and the
/// resolved path when the file does not exist.
std::filesystem::path resolveScenePath(const std::filesystem::path& scenesDir,
                                       std::string_view sceneId);

/// `root / split / (split + ".json.gz")`, the public layout.
std::filesystem::path splitEpisodesPath(const std::filesystem::path& root,
                                        std::string_view split);

/// `root / split / (split + "_gt.json.gz")`, the public layout.
std::filesystem::path splitGroundTruthPath(const std::filesystem::path& root,
                                           std::string_view split);

}  // namespace vln::data
