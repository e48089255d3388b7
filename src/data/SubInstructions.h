#pragma once
// Sub-instructions: which stretch of an instruction describes which leg of
// its reference path, in the spirit of Fine-Grained R2R's "chunk_view"
// (Hong et al. 2020, "Sub-Instruction Aware Vision-and-Language
// Navigation"). A file of this project, written by world::generateWorld()
// for the training splits (train, train_aug, train_extra) and, with
// splits.evaluation_sub_instructions, for the validation splits as new files
// beside their frozen ones, `{split}/{split}_sub_instructions.json.gz`:
//   {"<episode_id>": [{"begin": int, "end": int, "leg": int}, ...], ...}
// [begin, end) are byte offsets into the episode's instruction_text, in text
// order; `leg` is the reference path's leg the text describes: leg i runs
// from reference_path[i] to reference_path[i + 1], and leg
// reference_path.size() - 1 is the stop at the goal.

#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "common/Math.h"
#include "data/Episode.h"

namespace vln::data {

/// One clause of an instruction and the path leg it describes.
struct SubInstruction {
  int begin = 0;  ///< byte offset into instruction_text
  int end = 0;    ///< one past the last byte
  int leg = 0;    ///< reference path leg; reference_path.size() - 1 = stop
  bool operator==(const SubInstruction&) const = default;
};

/// The sub-instructions of a split, keyed by episode id.
using SubInstructions = std::map<int, std::vector<SubInstruction>>;

/// `<root>/<split>/<split>_sub_instructions.json.gz`.
std::filesystem::path splitSubInstructionsPath(
    const std::filesystem::path& root, std::string_view split);

/// Reads a sub-instruction file (.json or .json.gz). Throws
/// std::runtime_error for missing or truncated files and
/// std::invalid_argument naming the file, the episode id and the field for
/// keys that are not episode ids, missing fields, non-integers, negative
/// offsets or legs and end < begin.
SubInstructions readSubInstructions(const std::filesystem::path& file);

/// Atomically writes `subInstructions` to `file` (gzip when it ends in
/// .gz). Throws std::invalid_argument (leaving no file) for what
/// readSubInstructions() would refuse.
void writeSubInstructions(const std::filesystem::path& file,
                          const SubInstructions& subInstructions);

/// Checks `subInstructions` against the episodes they describe: every
/// episode has an entry, every span lies within its instruction_text and
/// every leg within its reference path (size() - 1 at most). Throws
/// std::invalid_argument naming `source`, the episode and the field.
void checkSubInstructions(const SubInstructions& subInstructions,
                          const std::vector<Episode>& episodes,
                          std::string_view source);

/// A sub-instruction as a range of tokenize(instruction_text)'s tokens.
struct SubInstructionTokens {
  int first = 0;  ///< index of its first token
  int last = 0;   ///< one past its last token
  int leg = 0;
};

/// The token ranges of `subInstructions` in tokenize(text): a span's first
/// token is the number of tokens of the text before `begin`, its end the
/// number before `end` (spans start and end at word boundaries, as the
/// generator's clauses do). Offsets beyond the text are clamped to it.
std::vector<SubInstructionTokens> subInstructionTokens(
    std::string_view text, const std::vector<SubInstruction>& subInstructions);

/// The leg of `path` (reference_path, at least two points) an agent at
/// `position` is about to walk: the position is projected onto the
/// nearest segment (3D), moved `lookahead` metres further along the path,
/// and the leg holding that point returned; path.size() - 1 (the stop)
/// once that point reaches the path's end.
int upcomingLeg(const std::vector<Vec3f>& path, const Vec3f& position,
                float lookahead);

/// How far past its projection onto the reference path an agent's position
/// is moved to tell the leg it is about to walk (upcomingLeg()): a waypoint
/// agent decides where its last waypoint ended, often a little short of or
/// past a reference node; half a metre on lies on the next leg.
inline constexpr float kLegLookahead = 0.5f;

/// The clauses an agent at `position` follows next: those of the first leg
/// at or after upcomingLeg(path, position, kLegLookahead) that some clause
/// of `clauses` describes (a straight leg is often left unsaid); empty when
/// none is left or `path` has fewer than two points.
std::vector<SubInstructionTokens> clausesAhead(
    const std::vector<SubInstructionTokens>& clauses,
    const std::vector<Vec3f>& path, const Vec3f& position);

/// The clauses of `text` as a rule finds them, with no sub-instruction
/// file (what an agent can know at test time): the text is cut after each
/// of . , ; : ! ? and before each word "and" or "then" (not before a "then"
/// right after "and"), and the pieces' token ranges in tokenize(text) are
/// returned in order, empty pieces dropped. `leg` is the clause's index.
/// On the default world's train_extra the cuts find 98.2% of the
/// generator's clause starts, 0.889 of them being one (docs/waypoints.md).
std::vector<SubInstructionTokens> ruleClauses(std::string_view text);

/// The index of the clause of `clauses` (in token order, as ruleClauses()
/// returns them) holding token `token`: the last one starting at or before
/// it; 0 when none does or `clauses` is empty.
int clauseHolding(const std::vector<SubInstructionTokens>& clauses, int token);

}  // namespace vln::data
