#pragma once
// Runs an Agent over a split's episodes in a VectorEnv and computes VLN-CE's
// metrics (Metrics.h) from the recorded paths.

#include <functional>
#include <optional>
#include <vector>

#include "data/Episode.h"
#include "data/GroundTruth.h"
#include "eval/Agent.h"
#include "eval/EvalConfig.h"
#include "eval/Metrics.h"
#include "eval/VectorEnv.h"

namespace vln::eval {

/// Everything one evaluation produced.
struct EvaluationResult {
  std::vector<EpisodeResult> episodes;  ///< in the order of the input episodes
  SplitStats stats;                     ///< means over `episodes`
};

/// Runs `agent` on every episode (batched over envs.size() environments,
/// argmax or sampling is the agent's business) until STOP or the step limit,
/// recording positions, headings and actions, then computes the metrics.
/// Reference paths come from `groundTruth` locations when given (else the
/// episode's reference_path). Episodes without goals (test split) are run
/// and recorded but get no metrics (stats over the others). `progress`, when
/// set, is called after each finished episode with (done, total).
EvaluationResult evaluateEpisodes(
    Agent& agent, VectorEnv& envs, const std::vector<data::Episode>& episodes,
    const data::GroundTruth* groundTruth, const EvalConfig& config,
    const std::function<void(int, int)>& progress = {});

}  // namespace vln::eval
