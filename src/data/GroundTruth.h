#pragma once
// Ground-truth action sequences of R2R_VLNCE, `{split}/{split}_gt.json.gz`:
//   {"<episode_id>": {"locations": [[x, y, z], ...], "actions": [int, ...],
//                     "forward_steps": int}, ...}
// In the public files `actions` is the shortest-path follower's sequence
// along the reference path (ending with STOP = 0), `forward_steps` counts its
// MOVE_FORWARD actions and `locations` holds the start position followed by
// the position after every MOVE_FORWARD (forward_steps + 1 entries), world
// frame, metres.

#include <filesystem>
#include <map>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "common/Math.h"
#include "sim/Agent.h"

namespace vln::data {

/// The reference action sequence of one episode.
struct GroundTruthPath {
  std::vector<Vec3f> locations;      ///< world frame, metres
  std::vector<sim::Action> actions;  ///< codes 0..3 in the file
  int forward_steps = 0;
  bool operator==(const GroundTruthPath&) const = default;
};

/// Ground truth of a split, keyed by episode id.
using GroundTruth = std::map<int, GroundTruthPath>;

/// Reads a ground-truth file (.json or .json.gz). Throws
/// std::runtime_error for missing or truncated files and
/// std::invalid_argument naming the file, the episode id and the field for
/// a key that is not an integer, missing fields, wrong types, non-finite
/// locations, actions outside 0..3 and a negative forward_steps.
GroundTruth readGroundTruth(const std::filesystem::path& file);

/// Parses the root object of a ground-truth file; `source` names it in
/// errors.
GroundTruth parseGroundTruth(const nlohmann::json& root,
                             std::string_view source);

/// The root JSON object of a ground-truth file.
nlohmann::json groundTruthToJson(const GroundTruth& groundTruth);

/// Atomically writes `groundTruth` to `file` (gzip when it ends in .gz).
/// Throws std::invalid_argument (leaving no file) on non-finite locations
/// or a negative forward_steps.
void writeGroundTruth(const std::filesystem::path& file,
                      const GroundTruth& groundTruth);

}  // namespace vln::data
