#pragma once
// VLN-CE's evaluation metrics as pure functions over a recorded episode,
// their per-split aggregation, and the files the evaluator writes.
//
// Every definition follows the code that produced the paper's numbers:
// jacobkrantz/VLN-CE habitat_extensions/measures.py (PathLength,
// OracleNavigationError, OracleSuccess, OracleSPL, NDTW, SDTW, StepsTaken)
// and habitat-lab
// habitat/tasks/nav/nav.py (DistanceToGoal, Success, SPL), with VLN-CE's
// SUCCESS_DISTANCE of 3.0 m. Positions are in the Habitat world frame
// (+Y up, metres). Geodesic distances come from a caller-supplied function,
// so the navmesh stays outside this file.
//
// Files (all written atomically):
//  - stats_ckpt_<idx>_<split>.json: per-split means with VLN-CE's keys
//    (distance_to_goal, success, spl, ndtw, path_length, oracle_success,
//    oracle_navigation_error, oracle_spl, steps_taken) plus sdtw and
//    num_episodes, as VLN-CE's
//    _eval_checkpoint() writes them.
//  - episodes_ckpt_<idx>_<split>.json(.gz): one entry per episode with its
//    metrics, agent path (positions and headings), actions and reference
//    path (see episodesToJson()).
//  - R2R leaderboard predictions for the test split:
//    {"<episode_id>": [{"position": [x, y, z], "heading": h, "stop": b},
//    ...]} as VLN-CE's inference() writes them.

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/Check.h"
#include "common/Math.h"

namespace vln::rollout {

/// VLN-CE's success radius: SUCCESS_DISTANCE 3.0 in
/// habitat_extensions/config/vlnce_task.yaml, also the nDTW normaliser.
inline constexpr double kSuccessDistance = 3.0;

/// Geodesic (navmesh shortest-path) distance between two world points,
/// metres; +infinity when no path exists.
using GeodesicFn = std::function<float(const Vec3f& from, const Vec3f& to)>;

/// How DTW is computed for nDTW. VLN-CE's NDTW measure uses `dtw` (exact,
/// the dtw==1.4.0 package) unless its FDTW flag selects `fastdtw` (the
/// fastdtw==0.3.4 package, radius 1).
enum class DtwMethod { kExact, kFast };

/// Options of computeEpisodeMetrics().
struct MetricsOptions {
  /// Success / oracle-success radius and nDTW normaliser (metres).
  double success_distance = kSuccessDistance;
  DtwMethod dtw = DtwMethod::kExact;
  /// FastDTW neighbourhood radius (fastdtw's default, used by VLN-CE).
  int fastdtw_radius = 1;
};

/// One decision of a waypoint agent (rollout/WaypointAgent.h), for maps:
/// where the agent stood, its candidate waypoints (world frame, metres) and
/// the one it chose (-1: STOP). Where the episode's goal is known, also the
/// goal oracle's verdict on the same candidates (waypoint::oracleVerdict()):
/// its choice and, per candidate, the geodesic distance from where that
/// candidate's execution ends to the goal (infinity when unreachable; empty
/// when the oracle planned nothing, within its stop distance). With
/// model.clause_tracker, the clause the decision read from (its pointer).
struct WaypointChoice {
  /// `oracle` when the goal was not known (a test split without its
  /// ground truth).
  static constexpr int kNoOracle = -2;
  Vec3f position = Vec3f::Zero();
  std::vector<Vec3f> candidates;
  int chosen = -1;
  int oracle = kNoOracle;
  std::vector<float> end_distances;
  /// data::ruleClauses() index; -1 without model.clause_tracker
  int clause = -1;
};

/// One evaluated episode as the evaluator records it.
struct EpisodeRecord {
  std::string episode_id;
  /// Agent positions (world frame, metres): the position after reset, then
  /// one per action taken (STOP included), so size() == steps_taken + 1.
  std::vector<Vec3f> positions;
  /// Headings (radians, Math.h convention) matching `positions`, or empty
  /// when not recorded (then no leaderboard entry can be written).
  std::vector<float> headings;
  /// Camera pitches (radians, positive up; sim::AgentState) matching
  /// `positions`, recorded only in the RxR action space
  /// (sim.agent.look_actions); empty otherwise.
  std::vector<float> pitches;
  /// Action codes taken (sim::Action values: 0 STOP, 1 MOVE_FORWARD,
  /// 2 TURN_LEFT, 3 TURN_RIGHT, and in RxR's action space 4 LOOK_UP,
  /// 5 LOOK_DOWN; 6 TELEPORT for a teleporting waypoint agent's steps), or
  /// empty when not recorded; when present size() == steps_taken.
  std::vector<int> actions;
  /// True when the episode ended by STOP (false when it hit the step limit).
  bool called_stop = false;
  /// Actions taken, STOP included (VLN-CE's steps_taken).
  int steps_taken = 0;
  /// Goal position (world frame, metres).
  Vec3f goal = Vec3f::Zero();
  /// Ground-truth locations for nDTW (the "locations" of the split's
  /// *_gt.json.gz), world frame, metres.
  std::vector<Vec3f> reference_path;
  /// d0: geodesic distance from the start to the goal at reset, metres
  /// (Habitat's SPL takes DistanceToGoal at reset).
  double start_distance = 0.0;
  /// A waypoint agent's decisions in order (Agent::waypointChoices());
  /// empty for low-level agents. Drawn on maps, and written to the
  /// episodes file as "waypoint_choices" (position, candidates, chosen:
  /// -1 for STOP) when not empty.
  std::vector<WaypointChoice> waypoint_choices;
};

/// The per-episode metrics, named by VLN-CE's measure uuids.
struct EpisodeMetrics {
  double distance_to_goal = 0.0;  ///< NE: geodesic to goal at the end (m)
  double success = 0.0;           ///< SR: 1 when STOP within the radius
  double spl = 0.0;               ///< success * d0 / max(d0, TL)
  double ndtw = 0.0;              ///< normalised DTW to the reference path
  double sdtw = 0.0;              ///< success * ndtw
  double path_length = 0.0;       ///< TL: sum of 3-D step lengths (m;
                                  ///< a teleport's is its straight segment)
  double oracle_success = 0.0;    ///< OS: 1 when ever within the radius
  double oracle_navigation_error = 0.0;  ///< ONE: nearest to goal (m)
  double oracle_spl = 0.0;   ///< SPL had the agent stopped on first arrival
  double steps_taken = 0.0;  ///< actions taken, STOP included
  bool operator==(const EpisodeMetrics&) const = default;
};

/// Every metric of EpisodeMetrics with its VLN-CE name, in declaration
/// order: the one list the files, the logs and the multi-process sums use.
inline constexpr std::array<std::pair<const char*, double EpisodeMetrics::*>,
                            10>
    kMetricFields{
        {{"distance_to_goal", &EpisodeMetrics::distance_to_goal},
         {"success", &EpisodeMetrics::success},
         {"spl", &EpisodeMetrics::spl},
         {"ndtw", &EpisodeMetrics::ndtw},
         {"sdtw", &EpisodeMetrics::sdtw},
         {"path_length", &EpisodeMetrics::path_length},
         {"oracle_success", &EpisodeMetrics::oracle_success},
         {"oracle_navigation_error", &EpisodeMetrics::oracle_navigation_error},
         {"oracle_spl", &EpisodeMetrics::oracle_spl},
         {"steps_taken", &EpisodeMetrics::steps_taken}}};

/// Metrics that files written before they existed lack: reading such a
/// file gives NaN for them (tables print "-"), not an error.
inline constexpr std::array<const char*, 2> kMetricsAddedLater{
    "oracle_navigation_error", "oracle_spl"};
/// True when stats key `key` is one of kMetricsAddedLater.
inline bool addedLaterMetric(std::string_view key) {
  for (const char* later : kMetricsAddedLater)
    if (key == later) return true;
  return false;
}

/// {"distance_to_goal": ..., ..., "steps_taken": ...} (kMetricFields).
nlohmann::json metricsToJson(const EpisodeMetrics& metrics);

/// Means of EpisodeMetrics over a split (the stats_ckpt file).
struct SplitStats {
  EpisodeMetrics mean;
  int num_episodes = 0;
  bool operator==(const SplitStats&) const = default;
};

/// A record with its metrics (one entry of the per-episode file).
struct EpisodeResult {
  EpisodeRecord record;
  EpisodeMetrics metrics;
};

/// Result of a DTW computation: the accumulated cost (sum of point
/// distances along the warping path) and the path as (i, j) index pairs
/// from (0, 0) to (n-1, m-1).
struct DtwResult {
  double distance = 0.0;
  std::vector<std::pair<int, int>> path;
};

// --- single metrics -------------------------------------------------------

/// TL: sum of 3-D Euclidean distances between consecutive positions
/// (VLN-CE PathLength), metres; 0 for fewer than two positions.
double pathLength(std::span<const Vec3f> positions);

/// OS: true when the geodesic distance to `goal` is < `successDistance` at
/// any position, the start included (VLN-CE OracleSuccess, which updates on
/// reset and after every step).
bool oracleSuccess(std::span<const Vec3f> positions, const Vec3f& goal,
                   const GeodesicFn& geodesic,
                   double successDistance = kSuccessDistance);

/// ONE: the smallest geodesic distance to `goal` over `positions`, the start
/// included (VLN-CE OracleNavigationError, which updates on reset and after
/// every step), metres; +infinity when no position has a path to the goal.
/// OS is ONE < successDistance.
double oracleNavigationError(std::span<const Vec3f> positions,
                             const Vec3f& goal, const GeodesicFn& geodesic);

/// Oracle SPL: d0 / max(d0, TL so far) at the first position after a step
/// whose geodesic distance to `goal` is < `successDistance`, 0 when there is
/// none: SPL had the agent stopped where it first arrived (OracleSPL of
/// VLN-CE's v1 measures.py, which updates after steps only). VLN-CE's later
/// measures.py takes the maximum of habitat's SPL over the steps instead,
/// which is SPL itself (habitat's success needs STOP), so it would add
/// nothing to the tables.
double oracleSplScore(std::span<const Vec3f> positions, const Vec3f& goal,
                      const GeodesicFn& geodesic, double startDistance,
                      double successDistance = kSuccessDistance);

/// SR: STOP was called and the final geodesic distance is strictly below
/// `successDistance` (habitat-lab Success uses `<`). Reaching the step limit
/// without STOP is a failure.
bool isSuccess(bool calledStop, double finalDistance,
               double successDistance = kSuccessDistance);

/// SPL = success * d0 / max(d0, TL) (habitat-lab SPL). When d0 and TL are
/// both 0 a successful episode scores 1 (Habitat would divide 0 by 0).
double splScore(bool success, double startDistance, double pathLength);

/// Positions with consecutive duplicates removed: VLN-CE's NDTW appends the
/// current position only when it differs from the last one kept.
std::vector<Vec3f> dedupConsecutive(std::span<const Vec3f> positions);

/// Exact DTW with Euclidean point distance (the `dtw` 1.4.0 package:
/// D[i][j] = d(a_i, b_j) + min(D[i-1][j-1], D[i-1][j], D[i][j-1]), cost not
/// normalised). Throws std::invalid_argument for an empty sequence.
DtwResult dtw(std::span<const Vec3d> a, std::span<const Vec3d> b);

/// FastDTW (Salvador & Chan 2007) exactly as the compiled fastdtw 0.3.4
/// package computes it (its Cython module, which `import fastdtw` loads):
/// recursive halving by pairwise averaging, full DTW below radius + 2
/// points, a window of `radius` cells around the projected path, and the
/// package's tie-breaking. `radius` >= 1. An upper bound of dtw().
DtwResult fastDtw(std::span<const Vec3d> a, std::span<const Vec3d> b,
                  int radius = 1);

/// 1-D variants (|a - b| point distance) of dtw() and fastDtw(), for
/// checking against the packages' documented examples.
DtwResult dtw1d(std::span<const double> a, std::span<const double> b);
DtwResult fastDtw1d(std::span<const double> a, std::span<const double> b,
                    int radius = 1);

/// nDTW = exp(-DTW(agent, reference) / (|reference| * successDistance))
/// (Magalhaes et al. 2019, VLN-CE NDTW): the agent positions are
/// deduplicated first (dedupConsecutive()); Euclidean 3-D point distance.
/// Throws std::invalid_argument for empty inputs.
double ndtwScore(std::span<const Vec3f> positions,
                 std::span<const Vec3f> reference,
                 double successDistance = kSuccessDistance,
                 DtwMethod method = DtwMethod::kExact, int fastdtwRadius = 1);

/// All metrics of one episode. Throws std::invalid_argument naming the
/// episode when the record is inconsistent (no positions, positions.size()
/// != steps_taken + 1, mismatched headings/actions, empty reference path,
/// negative or non-finite d0) or when the final geodesic distance is not
/// finite (VLN-CE episodes are navigable by construction).
EpisodeMetrics computeEpisodeMetrics(const EpisodeRecord& record,
                                     const GeodesicFn& geodesic,
                                     const MetricsOptions& options = {});

// --- aggregation ----------------------------------------------------------

/// Means over `episodes` (VLN-CE: sum / num_episodes for every key).
/// Throws std::invalid_argument when `episodes` is empty.
SplitStats aggregate(std::span<const EpisodeMetrics> episodes);

/// Means of the `fields` of `episodes` as a Stats (`mean`, `num_episodes`):
/// aggregate() and the nav-graph comparison's eval::aggregateGraph(). Throws
/// std::invalid_argument naming `caller` when `episodes` is empty.
template <class Stats, class Metrics, size_t N>
Stats averageMetrics(
    std::span<const Metrics> episodes,
    const std::array<std::pair<const char*, double Metrics::*>, N>& fields,
    std::string_view caller) {
  VLN_CHECK_ARG(!episodes.empty(), caller, ": no episodes to average");
  Stats stats;
  stats.num_episodes = static_cast<int>(episodes.size());
  for (const auto& [key, member] : fields) {
    double sum = 0.0;
    for (const auto& e : episodes) sum += e.*member;
    stats.mean.*member = sum / static_cast<double>(episodes.size());
  }
  return stats;
}

// --- files ----------------------------------------------------------------

/// "stats_ckpt_<checkpoint>_<split>.json".
std::string statsFileName(int checkpoint, std::string_view split);
/// "episodes_ckpt_<checkpoint>_<split>.json.gz".
std::string episodesFileName(int checkpoint, std::string_view split);

/// {"distance_to_goal": ..., ..., "sdtw": ..., "num_episodes": n}.
nlohmann::json statsToJson(const SplitStats& stats);
/// Inverse of statsToJson(); `source` names the file in errors.
SplitStats statsFromJson(const nlohmann::json& json, std::string_view source);
/// Atomically writes stats to `dir`/statsFileName(); returns the path.
std::filesystem::path writeStatsFile(const std::filesystem::path& dir,
                                     int checkpoint, std::string_view split,
                                     const SplitStats& stats);
/// Reads a stats file; errors name the file and the field.
SplitStats readStatsFile(const std::filesystem::path& file);

/// Per-episode file content: {"episodes": [{"episode_id", "metrics": {...},
/// "called_stop", "steps_taken", "goal", "start_distance", "path":
/// {"positions": [[x,y,z]...], "headings": [...]} (plus "pitches": [...]
/// when recorded), "actions": [...], "reference_path": [[x,y,z]...]}, ...]}.
nlohmann::json episodesToJson(std::span<const EpisodeResult> episodes);
/// Inverse of episodesToJson(); errors name `source`, the episode and field.
std::vector<EpisodeResult> episodesFromJson(const nlohmann::json& json,
                                            std::string_view source);
/// Atomically writes the per-episode file (gzip when `file` ends in .gz).
void writeEpisodesFile(const std::filesystem::path& file,
                       std::span<const EpisodeResult> episodes);
/// Reads a per-episode file.
std::vector<EpisodeResult> readEpisodesFile(const std::filesystem::path& file);

/// One step of an R2R leaderboard trajectory.
struct LeaderboardStep {
  Vec3f position = Vec3f::Zero();  ///< world frame, metres
  float heading = 0.0f;            ///< radians, Math.h convention
  bool stop = false;               ///< STOP has been called at this step
  bool operator==(const LeaderboardStep&) const = default;
};
/// Episode id -> steps, sorted by episode id (JSON object key order).
using LeaderboardPredictions =
    std::vector<std::pair<std::string, std::vector<LeaderboardStep>>>;

/// Leaderboard steps of one record: one per position (start included), with
/// stop true only on the final step of an episode that called STOP. Throws
/// std::invalid_argument naming the episode when headings were not recorded.
std::vector<LeaderboardStep> leaderboardSteps(const EpisodeRecord& record);
/// {"<episode_id>": [{"position", "heading", "stop"}, ...], ...}.
nlohmann::json leaderboardToJson(const LeaderboardPredictions& predictions);
/// Inverse of leaderboardToJson(); errors name `source`, episode and field.
LeaderboardPredictions leaderboardFromJson(const nlohmann::json& json,
                                           std::string_view source);
/// Atomically writes the predictions of `records` to `file`.
void writeLeaderboardFile(const std::filesystem::path& file,
                          std::span<const EpisodeRecord> records);
/// Reads a leaderboard predictions file.
LeaderboardPredictions readLeaderboardFile(const std::filesystem::path& file);

}  // namespace vln::rollout
