#pragma once
// `eval --dump DIR`: observation dumps (viz/ObservationDump.h, layout in
// docs/dumps.md) of the evaluated episodes, for any agent the eval binary
// runs (a checkpoint, an export, a baseline or the oracle):
//
//   eval ... --dump DIR [--dump-episodes N | --dump-ids 12,40]
//            [--dump-format png|jpg]
//
// writes DIR/<split>/<episode_id>/ for the first N episodes of every
// evaluated split (default: all of them) or for the listed episode ids.

#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "data/Split.h"
#include "train/ExperimentConfig.h"
#include "viz/ObservationDump.h"

namespace vln::eval {

/// The dump flags of the eval command.
struct DumpOptions {
  /// --dump: root directory of the dump; empty: no dump.
  std::filesystem::path dir;
  /// --dump-episodes: the first N episodes of each split; unset: all (or
  /// the ids).
  std::optional<int> episodes;
  /// --dump-ids: comma-separated episode ids; empty: none listed.
  std::string ids;
  /// --dump-format: RGB as "png" or "jpg".
  std::string format = "png";
};

/// The episode ids of `text` ("12,40, 7"): decimal integers >= 0 separated
/// by commas, spaces allowed around them. Throws std::invalid_argument
/// naming `flag` on an empty list, an empty entry, a non-number or a
/// duplicate.
std::vector<int> parseEpisodeIds(std::string_view text, std::string_view flag);

/// Checks the dump flags before anything runs. Throws
/// std::invalid_argument naming the flag when --dump-episodes, --dump-ids
/// or a --dump-format other than png come without --dump, when
/// --dump-episodes is below 1, both --dump-episodes and --dump-ids are
/// given, --dump-format is neither png nor jpg, an id of --dump-ids is in
/// none of `splits` (after --episodes), or `candidates` (what is evaluated)
/// is more than one (a directory of checkpoints would dump into one
/// folder); and, as the viz::ObservationDump constructor, when the folder
/// of an episode to dump exists already.
void checkDumpOptions(const DumpOptions& options,
                      std::span<const data::Split> splits, size_t candidates,
                      const train::ExperimentConfig& config);

/// The dump observer of `split` for the agent called `agent`, with
/// `config`'s cameras; null without --dump. Throws what the
/// viz::ObservationDump constructor throws (an episode folder that exists).
std::unique_ptr<viz::ObservationDump> makeObservationDump(
    const DumpOptions& options, const data::Split& split,
    const train::ExperimentConfig& config, const std::string& agent);

}  // namespace vln::eval
