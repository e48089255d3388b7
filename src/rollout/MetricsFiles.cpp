// The files the evaluator writes and reads (see rollout/Metrics.h):
// stats, per-episode and leaderboard files, and their JSON.
#include "rollout/Metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string_view>

#include "common/Check.h"
#include "common/Json.h"
#include "sim/Agent.h"

namespace vln::rollout {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// ---------------------------------------------------------------------------
// JSON helpers
// ---------------------------------------------------------------------------

nlohmann::json vecToJson(const Vec3f& v) { return {v.x(), v.y(), v.z()}; }

Vec3f vecFromJson(const nlohmann::json& j, const std::string& where) {
  VLN_CHECK_ARG(j.is_array() && j.size() == 3 && j[0].is_number() &&
                    j[1].is_number() && j[2].is_number(),
                where, " must be [x, y, z], got ", j.dump());
  return {j[0].get<float>(), j[1].get<float>(), j[2].get<float>()};
}

nlohmann::json pointsToJson(std::span<const Vec3f> points) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& p : points) out.push_back(vecToJson(p));
  return out;
}

std::vector<Vec3f> pointsFromJson(const nlohmann::json& j,
                                  const std::string& where) {
  VLN_CHECK_ARG(j.is_array(), where, " must be an array of [x, y, z], got ",
                j.type_name());
  std::vector<Vec3f> out;
  out.reserve(j.size());
  for (size_t i = 0; i < j.size(); ++i)
    out.push_back(vecFromJson(j[i], strCat(where, "[", i, "]")));
  return out;
}

// A number field; JSON null (how nlohmann writes inf/NaN) reads as +inf.
double numberField(const nlohmann::json& object, const char* key,
                   const std::string& where) {
  auto it = object.find(key);
  VLN_CHECK_ARG(it != object.end(), where, ": field '", key, "' is missing");
  if (it->is_null()) return kInf;
  VLN_CHECK_ARG(it->is_number(), where, ": field '", key,
                "' must be a number, got ", it->dump());
  return it->get<double>();
}

EpisodeMetrics metricsFromJson(const nlohmann::json& j,
                               const std::string& where) {
  VLN_CHECK_ARG(j.is_object(), where, ": expected a JSON object, got ",
                j.type_name());
  EpisodeMetrics m;
  for (const auto& [key, member] : kMetricFields) {
    m.*member = addedLaterMetric(key) && !j.contains(key)
                    ? std::numeric_limits<double>::quiet_NaN()
                    : numberField(j, key, where);
  }
  return m;
}

}  // namespace

nlohmann::json metricsToJson(const EpisodeMetrics& m) {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [key, member] : kMetricFields) out[key] = m.*member;
  return out;
}

// ---------------------------------------------------------------------------
// stats files
// ---------------------------------------------------------------------------

std::string statsFileName(int checkpoint, std::string_view split) {
  return strCat("stats_ckpt_", checkpoint, "_", split, ".json");
}

std::string episodesFileName(int checkpoint, std::string_view split) {
  return strCat("episodes_ckpt_", checkpoint, "_", split, ".json.gz");
}

nlohmann::json statsToJson(const SplitStats& stats) {
  nlohmann::json out = metricsToJson(stats.mean);
  out["num_episodes"] = stats.num_episodes;
  return out;
}

SplitStats statsFromJson(const nlohmann::json& json, std::string_view source) {
  const std::string where(source);
  SplitStats stats;
  stats.mean = metricsFromJson(json, where);
  auto it = json.find("num_episodes");
  VLN_CHECK_ARG(it != json.end(), where, ": field 'num_episodes' is missing");
  VLN_CHECK_ARG(it->is_number_integer() && it->get<int64_t>() > 0, where,
                ": field 'num_episodes' must be a positive integer, got ",
                it->dump());
  stats.num_episodes = it->get<int>();
  return stats;
}

std::filesystem::path writeStatsFile(const std::filesystem::path& dir,
                                     int checkpoint, std::string_view split,
                                     const SplitStats& stats) {
  const auto file = dir / statsFileName(checkpoint, split);
  common::writeJsonFile(file, statsToJson(stats), /*indent=*/4);
  return file;
}

SplitStats readStatsFile(const std::filesystem::path& file) {
  return statsFromJson(common::readJsonFile(file), file.string());
}

// ---------------------------------------------------------------------------
// per-episode files
// ---------------------------------------------------------------------------

nlohmann::json episodesToJson(std::span<const EpisodeResult> episodes) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& [r, m] : episodes) {
    nlohmann::json path = {{"positions", pointsToJson(r.positions)},
                           {"headings", r.headings}};
    // R2R records have no pitches, and their files stay as they were
    if (!r.pitches.empty()) path["pitches"] = r.pitches;
    nlohmann::json episode = {
        {"episode_id", r.episode_id},
        {"metrics", metricsToJson(m)},
        {"called_stop", r.called_stop},
        {"steps_taken", r.steps_taken},
        {"goal", vecToJson(r.goal)},
        {"start_distance", r.start_distance},
        {"path", std::move(path)},
        {"actions", r.actions},
        {"reference_path", pointsToJson(r.reference_path)}};
    // a waypoint agent's decisions, for analyses of what it was offered;
    // low-level agents' files stay as they were
    if (!r.waypoint_choices.empty()) {
      nlohmann::json choices = nlohmann::json::array();
      for (const WaypointChoice& c : r.waypoint_choices) {
        nlohmann::json choice = {{"position", vecToJson(c.position)},
                                 {"candidates", pointsToJson(c.candidates)},
                                 {"chosen", c.chosen}};
        if (c.oracle != WaypointChoice::kNoOracle) {
          choice["oracle"] = c.oracle;
          nlohmann::json ends = nlohmann::json::array();
          for (float d : c.end_distances)  // null: the goal is unreachable
            ends.push_back(std::isfinite(d) ? nlohmann::json(d)
                                            : nlohmann::json());
          choice["end_distances"] = std::move(ends);
        }
        if (c.clause >= 0) choice["clause"] = c.clause;
        choices.push_back(std::move(choice));
      }
      episode["waypoint_choices"] = std::move(choices);
    }
    list.push_back(std::move(episode));
  }
  return {{"episodes", std::move(list)}};
}

std::vector<EpisodeResult> episodesFromJson(const nlohmann::json& json,
                                            std::string_view source) {
  const std::string file(source);
  const auto list =
      common::requireField<nlohmann::json>(json, "episodes", file);
  VLN_CHECK_ARG(list.is_array(), file,
                ": field 'episodes' must be an array, got ", list.type_name());
  std::vector<EpisodeResult> out;
  out.reserve(list.size());
  for (size_t i = 0; i < list.size(); ++i) {
    const auto& e = list[i];
    const std::string where = strCat(file, ": episodes[", i, "]");
    EpisodeResult result;
    EpisodeRecord& r = result.record;
    r.episode_id = common::requireField<std::string>(e, "episode_id", where);
    const std::string ctx = strCat(file, ": episode '", r.episode_id, "'");
    result.metrics =
        metricsFromJson(common::requireField<nlohmann::json>(e, "metrics", ctx),
                        ctx + " metrics");
    r.called_stop = common::requireField<bool>(e, "called_stop", ctx);
    r.steps_taken = common::requireField<int>(e, "steps_taken", ctx);
    r.goal = vecFromJson(common::requireField<nlohmann::json>(e, "goal", ctx),
                         ctx + ": field 'goal'");
    r.start_distance = numberField(e, "start_distance", ctx);
    const auto path = common::requireField<nlohmann::json>(e, "path", ctx);
    r.positions = pointsFromJson(
        common::requireField<nlohmann::json>(path, "positions", ctx),
        ctx + ": field 'path.positions'");
    r.headings =
        common::requireField<std::vector<float>>(path, "headings", ctx);
    if (path.contains("pitches"))
      r.pitches =
          common::requireField<std::vector<float>>(path, "pitches", ctx);
    r.actions = common::requireField<std::vector<int>>(e, "actions", ctx);
    r.reference_path = pointsFromJson(
        common::requireField<nlohmann::json>(e, "reference_path", ctx),
        ctx + ": field 'reference_path'");
    if (e.contains("waypoint_choices")) {
      const auto choices =
          common::requireField<nlohmann::json>(e, "waypoint_choices", ctx);
      VLN_CHECK_ARG(choices.is_array(), ctx,
                    ": field 'waypoint_choices' must be an array, got ",
                    choices.type_name());
      for (size_t k = 0; k < choices.size(); ++k) {
        const std::string at = strCat(ctx, ": field 'waypoint_choices[", k, "]");
        WaypointChoice c;
        c.position = vecFromJson(
            common::requireField<nlohmann::json>(choices[k], "position", at),
            at + ".position'");
        c.candidates = pointsFromJson(
            common::requireField<nlohmann::json>(choices[k], "candidates", at),
            at + ".candidates'");
        // the agent's and the oracle's choices: -1 STOP, otherwise an index
        // into the candidates
        const int slots = static_cast<int>(c.candidates.size());
        auto choiceField = [&](const char* name) {
          const int choice = common::requireField<int>(choices[k], name, at);
          VLN_CHECK_ARG(choice >= -1 && choice < slots, at, ".", name,
                        "' must be -1 (STOP) or a candidate index 0..",
                        slots - 1, ", got ", choice);
          return choice;
        };
        c.chosen = choiceField("chosen");
        if (choices[k].contains("clause")) {
          c.clause = common::requireField<int>(choices[k], "clause", at);
          VLN_CHECK_ARG(c.clause >= 0, at,
                        ".clause' must be a clause index >= 0, got ", c.clause);
        }
        if (choices[k].contains("oracle")) {
          c.oracle = choiceField("oracle");
          const auto ends = common::requireField<nlohmann::json>(
              choices[k], "end_distances", at);
          VLN_CHECK_ARG(ends.is_array() && (ends.empty() ||
                                            ends.size() == c.candidates.size()),
                        at,
                        ".end_distances' must be an array of one number "
                        "(or null) per candidate, or empty");
          for (const auto& d : ends) {
            VLN_CHECK_ARG(d.is_null() || d.is_number(), at,
                          ".end_distances' must hold numbers or null, got ",
                          d.type_name());
            c.end_distances.push_back(
                d.is_null() ? std::numeric_limits<float>::infinity()
                            : d.get<float>());
          }
        }
        r.waypoint_choices.push_back(std::move(c));
      }
    }
    VLN_CHECK_ARG(r.positions.size() == static_cast<size_t>(r.steps_taken) + 1,
                  ctx, ": field 'path.positions' must hold steps_taken + 1 = ",
                  r.steps_taken + 1, " entries, got ", r.positions.size());
    // the low-level codes, and a teleporting waypoint agent's TELEPORT
    constexpr int kLastCode = static_cast<int>(sim::Action::kTeleport);
    for (size_t k = 0; k < r.actions.size(); ++k)
      VLN_CHECK_ARG(r.actions[k] >= 0 && r.actions[k] <= kLastCode, ctx,
                    ": field 'actions[", k, "]' must be an action code 0..",
                    kLastCode, ", got ", r.actions[k]);
    VLN_CHECK_ARG(r.pitches.empty() || r.pitches.size() == r.positions.size(),
                  ctx,
                  ": field 'path.pitches' must hold one pitch per "
                  "position (",
                  r.positions.size(), "), got ", r.pitches.size());
    out.push_back(std::move(result));
  }
  return out;
}

void writeEpisodesFile(const std::filesystem::path& file,
                       std::span<const EpisodeResult> episodes) {
  common::writeJsonFile(file, episodesToJson(episodes));
}

std::vector<EpisodeResult> readEpisodesFile(const std::filesystem::path& file) {
  return episodesFromJson(common::readJsonFile(file), file.string());
}

// ---------------------------------------------------------------------------
// leaderboard predictions
// ---------------------------------------------------------------------------

std::vector<LeaderboardStep> leaderboardSteps(const EpisodeRecord& record) {
  VLN_CHECK_ARG(!record.positions.empty() &&
                    record.headings.size() == record.positions.size(),
                "leaderboardSteps(): episode '", record.episode_id,
                "' needs one heading per position (", record.positions.size(),
                "), got ", record.headings.size());
  std::vector<LeaderboardStep> steps;
  steps.reserve(record.positions.size());
  for (size_t i = 0; i < record.positions.size(); ++i) {
    // VLN-CE reports task.is_stop_called after each step: only the state
    // after the STOP action carries stop = true
    const bool last = i + 1 == record.positions.size();
    steps.push_back({record.positions[i], wrapAngle(record.headings[i]),
                     record.called_stop && last && i > 0});
  }
  return steps;
}

nlohmann::json leaderboardToJson(const LeaderboardPredictions& predictions) {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [id, steps] : predictions) {
    VLN_CHECK_ARG(!out.contains(id),
                  "leaderboardToJson(): duplicate episode id '", id, "'");
    nlohmann::json list = nlohmann::json::array();
    for (const auto& s : steps)
      list.push_back({{"position", vecToJson(s.position)},
                      {"heading", s.heading},
                      {"stop", s.stop}});
    out[id] = std::move(list);
  }
  return out;
}

LeaderboardPredictions leaderboardFromJson(const nlohmann::json& json,
                                           std::string_view source) {
  const std::string file(source);
  VLN_CHECK_ARG(json.is_object(), file,
                ": expected an object of episode id -> steps, got ",
                json.type_name());
  LeaderboardPredictions out;
  for (const auto& [id, list] : json.items()) {
    const std::string ctx = strCat(file, ": episode '", id, "'");
    VLN_CHECK_ARG(list.is_array() && !list.empty(), ctx,
                  " must be a non-empty array of steps, got ", list.dump());
    std::vector<LeaderboardStep> steps;
    for (size_t i = 0; i < list.size(); ++i) {
      const std::string where = strCat(ctx, " step ", i);
      LeaderboardStep s;
      s.position = vecFromJson(
          common::requireField<nlohmann::json>(list[i], "position", where),
          where + ": field 'position'");
      s.heading = common::requireField<float>(list[i], "heading", where);
      s.stop = common::requireField<bool>(list[i], "stop", where);
      steps.push_back(s);
    }
    out.emplace_back(id, std::move(steps));
  }
  return out;
}

void writeLeaderboardFile(const std::filesystem::path& file,
                          std::span<const EpisodeRecord> records) {
  LeaderboardPredictions predictions;
  predictions.reserve(records.size());
  for (const auto& r : records)
    predictions.emplace_back(r.episode_id, leaderboardSteps(r));
  common::writeJsonFile(file, leaderboardToJson(predictions));
}

LeaderboardPredictions readLeaderboardFile(const std::filesystem::path& file) {
  return leaderboardFromJson(common::readJsonFile(file), file.string());
}

}  // namespace vln::rollout
