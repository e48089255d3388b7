#pragma once
// An HTML report of one evaluation (one checkpoint on one split): a page
// that opens from disk with no network and no server. A table of every
// episode, sortable by each metric; for the first episodes, the
// instruction, the top-down map with the reference and agent paths, the
// egocentric frames (RGB | depth) as a sequence scrubbed with a slider,
// the action taken at each step and, for agents that attend to the
// instruction (CMA), the attention over its words at each step,
// highlighted as the frames move. Deep links select an episode, a step and
// the sort order: index.html#episode=<id>&step=<k>&sort=<metric>&order=desc.
//
// Layout: <dir>/index.html (page, data inlined), <dir>/report.json (title
// and mean metrics, for the index of reports), <dir>/maps/episode_<id>.png,
// <dir>/frames/episode_<id>/step_<kkk>.jpg.

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "data/Vocabulary.h"
#include "rollout/Agent.h"
#include "rollout/Evaluator.h"
#include "viz/EpisodeMap.h"

namespace vln::viz {

struct ReportConfig {
  /// The report's folder (created on demand; files in it are replaced).
  std::filesystem::path dir;
  /// Page title, e.g. "checkpoint 7 on val_unseen".
  std::string title;
  /// Episodes at input positions < detail_episodes get a map and frames.
  int detail_episodes = 5;
  /// JPEG quality of the frames (1-100).
  int frame_quality = 90;
  MapStyle map;
  /// Success radius drawn around the goal, metres.
  float success_distance = 3.0f;
  /// What the instruction's tokens mean (the split's instruction_vocab);
  /// without it the attention is shown over token numbers.
  const data::Vocabulary* vocabulary = nullptr;
  /// Tokens the policy reads (dataset.max_instruction_length).
  int max_instruction_length = 200;
};

/// The rollout::EpisodeObserver that gathers a report during an evaluation;
/// write() puts it on disk. `agent`, when given, is asked for its attention
/// over the instruction after every step (call
/// agent->keepInstructionAttention(true) before evaluating).
class EpisodeReport : public rollout::EpisodeObserver {
 public:
  EpisodeReport(ReportConfig config, const rollout::Agent* agent);
  ~EpisodeReport() override;

  bool wantsFrames(int index) const override;
  void episodeStarted(int index, rollout::VectorEnv& envs, int env) override;
  void episodeStepped(int index, rollout::VectorEnv& envs, int env,
                      sim::Action action) override;
  void episodeFinished(int index, rollout::VectorEnv& envs, int env,
                       const rollout::EpisodeResult& result,
                       bool scored) override;

  /// Writes index.html and report.json (after the evaluation). Returns the
  /// page's path. Throws std::runtime_error naming a file it cannot write.
  std::filesystem::path write() const;

 private:
  struct Episode;
  ReportConfig config_;
  const rollout::Agent* agent_;
  std::map<int, std::unique_ptr<Episode>> running_;   ///< by environment
  std::map<int, std::unique_ptr<Episode>> finished_;  ///< by input position
};

/// Writes <root>/index.html linking every report in <root>'s subfolders
/// (those with a report.json), with their titles and mean metrics. Returns
/// its path.
std::filesystem::path writeReportIndex(const std::filesystem::path& root);

}  // namespace vln::viz
