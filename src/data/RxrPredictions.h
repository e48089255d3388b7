#pragma once
// The RxR-Habitat inference output, as VLN-CE's BaseVLNCETrainer.inference()
// writes it (INFERENCE.FORMAT "rxr") and the leaderboard reads it: a JSON
// lines file (.jsonl), one line per instruction, sorted by instruction_id:
//   {"instruction_id": 12, "path": [[x, y, z], ...]}
// `path` is the agent's position (world frame, metres, +Y up) at the start
// and after every step that moved it: consecutive equal positions appear
// once. scripts/merge_inference_predictions.py merges the files of several
// languages into one, sorted, with unique ids; mergeRxrPredictions() does
// the same and refuses what that script would pass silently (malformed
// lines, blank lines, unknown keys).

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "common/Math.h"

namespace vln::data {

/// One line of the output.
struct RxrPrediction {
  int64_t instruction_id = 0;
  std::vector<Vec3f> path;  ///< world frame, metres; never empty
  bool operator==(const RxrPrediction&) const = default;
};

/// `positions` (one per step, the start first) without consecutive repeats,
/// as VLN-CE keeps "only positions that changed".
std::vector<Vec3f> rxrPathFromPositions(const std::vector<Vec3f>& positions);

/// The .jsonl text of `predictions`, sorted by instruction_id, one line
/// each, ending in a newline. Throws std::invalid_argument for a duplicate
/// or negative id, an empty path or a non-finite position.
std::string rxrPredictionsToJsonl(std::vector<RxrPrediction> predictions);

/// Atomically writes rxrPredictionsToJsonl(predictions) to `file`.
void writeRxrPredictions(const std::filesystem::path& file,
                         std::vector<RxrPrediction> predictions);

/// Parses .jsonl text (file order); `source` names it in errors. Each line
/// must be an object with exactly the keys instruction_id (an integer >= 0)
/// and path (a non-empty list of finite [x, y, z]); blank lines are refused
/// except for one final newline, as are duplicate ids. Errors name the
/// source and the line ("'en.jsonl': line 3: ...").
std::vector<RxrPrediction> parseRxrPredictions(std::string_view text,
                                               std::string_view source);

/// Reads a .jsonl file (see parseRxrPredictions()); std::runtime_error for
/// a missing file.
std::vector<RxrPrediction> readRxrPredictions(
    const std::filesystem::path& file);

/// The predictions of all `files` (e.g. one per language), sorted by
/// instruction_id. Throws std::invalid_argument naming both files and
/// lines when an id appears twice.
std::vector<RxrPrediction> mergeRxrPredictions(
    const std::vector<std::filesystem::path>& files);

/// mergeRxrPredictions(files) written atomically to `out`; returns the
/// number of lines written.
size_t mergeRxrPredictionFiles(const std::filesystem::path& out,
                               const std::vector<std::filesystem::path>& files);

}  // namespace vln::data
