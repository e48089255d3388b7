// scripts/failure_stages.py: each episode sorted into success, stopped near
// the goal, or lost in a third of the reference path, and how often the
// first forward step follows the path's first leg, as means over an agent's
// runs; with --by-decision, a waypoint agent's choices against the goal
// oracle's. Checked on hand-made episodes whose outcomes are worked out by
// hand, and on the inputs it must refuse. Skipped without /usr/bin/python3.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "common/Json.h"
#include "support/ProjectScripts.h"
#include "support/TestPaths.h"

namespace vln::eval {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

int runScript(const std::string& args, std::string* log) {
  return vln::test::runProjectScript("failure_stages.py", args, log);
}

// four episodes on the same straight path along +x: nodes every 2 m
void writeSplit(const fs::path& data) {
  nlohmann::json episodes = nlohmann::json::array();
  for (int i = 1; i <= 4; ++i)
    episodes.push_back(
        {{"episode_id", i},
         {"reference_path", {{0, 0, 0}, {2, 0, 0}, {4, 0, 0}, {6, 0, 0}}}});
  common::writeJsonFile(data / "val_unseen" / "val_unseen.json.gz",
                        {{"episodes", episodes}});
}

// Habitat's heading that faces +x (forward is (-sin h, 0, -cos h)), and
// the opposite one
const double kAlongPath = -M_PI / 2;
const double kAgainstPath = M_PI / 2;

nlohmann::json episode(int id, int success, int oracleSuccess,
                       const std::vector<std::vector<double>>& positions,
                       double heading, const std::vector<int>& actions) {
  return {{"episode_id", std::to_string(id)},
          {"actions", actions},
          {"path",
           {{"positions", positions},
            {"headings", std::vector<double>(positions.size(), heading)}}},
          {"metrics",
           {{"success", success}, {"oracle_success", oracleSuccess}}}};
}

void writeRun(const fs::path& dir, const std::vector<nlohmann::json>& episodes) {
  common::writeJsonFile(dir / "episodes_ckpt_2_val_unseen.json.gz",
                        {{"episodes", nlohmann::json(episodes)}});
}

TEST(FailureStagesScriptTest, OutcomesAndOpeningLegByHand) {
  if (!vln::test::havePython()) GTEST_SKIP() << "no /usr/bin/python3";
  vln::test::TempDir dir;
  writeSplit(dir / "data");
  const std::vector<std::vector<double>> walked{
      {0, 0, 0}, {1, 0, 0}, {2.2, 0, 0}, {2.2, 0, 3}};
  // seed 0: a success along the path; the goal area reached but the stop
  // elsewhere, first step against the path; node 1 of 3 passed (a third:
  // lost in the second third); never moved (lost in the first, opening
  // not judged)
  writeRun(dir / "a" / "seed0",
           {episode(1, 1, 1, walked, kAlongPath, {1, 1, 1, 0}),
            episode(2, 0, 1, walked, kAgainstPath, {1, 1, 1, 0}),
            episode(3, 0, 0, walked, kAlongPath, {3, 1, 1, 0}),
            episode(4, 0, 0, {{0, 0, 0}}, kAlongPath, {0})});
  // seed 1: all four succeed; the last one never moved
  writeRun(dir / "a" / "seed1",
           {episode(1, 1, 1, walked, kAlongPath, {1, 1, 1, 0}),
            episode(2, 1, 1, walked, kAlongPath, {1, 1, 1, 0}),
            episode(3, 1, 1, walked, kAlongPath, {1, 1, 1, 0}),
            episode(4, 1, 1, {{0, 0, 0}}, kAlongPath, {0})});
  std::string log;
  ASSERT_EQ(runScript("--json --data " + (dir / "data").string() +
                          " --split val_unseen --agent A '" +
                          (dir / "a" / "seed*").string() + "'",
                      &log),
            0)
      << log;
  const nlohmann::json a = nlohmann::json::parse(log).at("A");
  EXPECT_EQ(a.at("runs"), 2);
  EXPECT_EQ(a.at("episodes"), 4);
  EXPECT_DOUBLE_EQ(a.at("success").get<double>(), (0.25 + 1.0) / 2);
  EXPECT_DOUBLE_EQ(a.at("stopped near goal").get<double>(), 0.125);
  EXPECT_DOUBLE_EQ(a.at("lost in 1st third").get<double>(), 0.125);
  EXPECT_DOUBLE_EQ(a.at("lost in 2nd third").get<double>(), 0.125);
  EXPECT_DOUBLE_EQ(a.at("lost in 3rd third").get<double>(), 0.0);
  // seed 0: 2 of 3 judged openings along the path; seed 1: 3 of 3
  EXPECT_NEAR(a.at("opening").get<double>(), (2.0 / 3 + 1.0) / 2, 1e-12);

  // the table form names the columns and the runs
  ASSERT_EQ(runScript("--data " + (dir / "data").string() +
                          " --split val_unseen --agent A '" +
                          (dir / "a" / "seed*").string() + "'",
                      &log),
            0)
      << log;
  EXPECT_THAT(log, HasSubstr("| A (2 x 4) | 0.625 | 0.125 | 0.125 | 0.125 | "
                             "0.000 | 0.833 | - | - |"));
}

// a waypoint agent's files carry its decisions: was a candidate along the
// first leg (+x) offered at the first one, and did the agent take it
TEST(FailureStagesScriptTest, OpeningOfferedToAWaypointAgent) {
  if (!vln::test::havePython()) GTEST_SKIP() << "no /usr/bin/python3";
  vln::test::TempDir dir;
  writeSplit(dir / "data");
  const std::vector<std::vector<double>> walked{{0, 0, 0}, {1, 0, 0}};
  auto offeredTo = [](nlohmann::json e,
                      const std::vector<std::vector<double>>& candidates) {
    e["waypoint_choices"] = {
        {{"position", {0, 0, 0}}, {"candidates", candidates}, {"chosen", 0}}};
    return e;
  };
  // 1: offered (+x, 6 degrees off) and taken; 2: only +z offered (90
  // degrees off); 3: offered, walked against the path; 4: offered, never
  // moved (not judged)
  writeRun(dir / "w",
           {offeredTo(episode(1, 0, 0, walked, kAlongPath, {1, 0}),
                      {{2, 0, 0.2}, {0, 0, 2}}),
            offeredTo(episode(2, 0, 0, walked, kAlongPath, {1, 0}),
                      {{0, 0, 2}}),
            offeredTo(episode(3, 0, 0, walked, kAgainstPath, {1, 0}),
                      {{2, 0, 0}}),
            offeredTo(episode(4, 0, 0, {{0, 0, 0}}, kAlongPath, {0}),
                      {{2, 0, 0}})});
  std::string log;
  ASSERT_EQ(runScript("--json --data " + (dir / "data").string() +
                          " --split val_unseen --agent W '" +
                          (dir / "w").string() + "'",
                      &log),
            0)
      << log;
  const nlohmann::json w = nlohmann::json::parse(log).at("W");
  EXPECT_DOUBLE_EQ(w.at("offered").get<double>(), 0.75);
  EXPECT_DOUBLE_EQ(w.at("right when offered").get<double>(), 0.5);
  EXPECT_NEAR(w.at("opening").get<double>(), 2.0 / 3, 1e-12);

  // a decision without candidates' coordinates is named
  nlohmann::json bad = offeredTo(episode(1, 0, 0, walked, kAlongPath, {1, 0}),
                                 {{2, 0, 0}});
  bad["waypoint_choices"][0]["candidates"] = {{2, 0}};
  writeRun(dir / "bad", {bad});
  EXPECT_NE(runScript("--data " + (dir / "data").string() +
                          " --split val_unseen --agent W '" +
                          (dir / "bad").string() + "'",
                      &log),
            0);
  EXPECT_THAT(log, HasSubstr("episode 1 has a waypoint_choices[0] without"));
}

// --by-first-turn: the openings grouped by the instruction's first turn
// phrase, relative to the start heading (the path runs along +x, Habitat
// heading -pi/2)
TEST(FailureStagesScriptTest, OpeningsByTheFirstTurnPhrase) {
  if (!vln::test::havePython()) GTEST_SKIP() << "no /usr/bin/python3";
  vln::test::TempDir dir;
  const std::vector<std::string> texts{
      "Turn left and walk to the door.", "Make a left, then stop.",
      "Veer right into the hallway.", "Walk forward to the sofa."};
  nlohmann::json split = nlohmann::json::array();
  for (int i = 1; i <= 4; ++i)
    split.push_back({{"episode_id", i},
                     {"instruction", {{"instruction_text", texts[i - 1]}}},
                     {"reference_path", {{0, 0, 0}, {2, 0, 0}, {4, 0, 0}}}});
  common::writeJsonFile(dir / "data" / "val_unseen" / "val_unseen.json.gz",
                        {{"episodes", split}});
  const std::vector<std::vector<double>> walked{
      {0, 0, 0}, {0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  auto withHeadings = [&](int id, const std::vector<double>& headings,
                          const std::vector<int>& actions) {
    nlohmann::json e = episode(id, 0, 0, walked, 0.0, actions);
    e["path"]["headings"] = headings;
    return e;
  };
  // heading h faces (-sin h, 0, -cos h). 1: starts facing +z (heading
  // -pi: the leg is 90 degrees to the left) and turns left onto it; 2: the
  // same start, turns right and walks -x (-90: the wrong side); 3: starts
  // facing -z (heading 0: the leg is 90 degrees to the right) and turns
  // right onto it; 4: never moves (not judged)
  writeRun(
      dir / "a",
      {withHeadings(1, {-M_PI, kAlongPath, kAlongPath, kAlongPath},
                    {2, 1, 1, 0}),
       withHeadings(2, {-M_PI, M_PI / 2, M_PI / 2, M_PI / 2}, {3, 1, 1, 0}),
       withHeadings(3, {0.0, kAlongPath, kAlongPath, kAlongPath}, {3, 1, 1, 0}),
       withHeadings(4, {kAlongPath, kAlongPath, kAlongPath, kAlongPath},
                    {0, 0, 0, 0})});
  std::string log;
  const std::string args = "--by-first-turn --data " + (dir / "data").string() +
                           " --split val_unseen --agent A '" +
                           (dir / "a").string() + "'";
  ASSERT_EQ(runScript("--json " + args, &log), 0) << log;
  const nlohmann::json rows = nlohmann::json::parse(log).at("A");
  ASSERT_EQ(rows.size(), 2u) << log;
  const nlohmann::json& left = rows[0];
  EXPECT_EQ(left.at("first turn"), "left");
  EXPECT_EQ(left.at("episodes"), 2);
  EXPECT_NEAR(left.at("leg median").get<double>(), 90.0, 1e-9);
  EXPECT_NEAR(left.at("opening median").get<double>(), 0.0, 1e-9);
  EXPECT_NEAR(left.at("opening p10").get<double>(), -90.0, 1e-9);
  EXPECT_DOUBLE_EQ(left.at("opening leg right").get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(left.at("wrong side").get<double>(), 0.5);
  const nlohmann::json& slight = rows[1];
  EXPECT_EQ(slight.at("first turn"), "slight right");
  EXPECT_EQ(slight.at("episodes"), 1);
  EXPECT_NEAR(slight.at("leg median").get<double>(), -90.0, 1e-9);
  EXPECT_DOUBLE_EQ(slight.at("opening leg right").get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(slight.at("wrong side").get<double>(), 0.0);
  // the table form
  ASSERT_EQ(runScript(args, &log), 0) << log;
  EXPECT_THAT(log, HasSubstr("| A | left | 2 | 90 | 0 [-90, 90] | 0.500 | "
                             "0.500 |"));

  // a split without instructions is named
  writeSplit(dir / "bare");
  EXPECT_NE(runScript("--by-first-turn --data " + (dir / "bare").string() +
                          " --split val_unseen --agent A '" +
                          (dir / "a").string() + "'",
                      &log),
            0);
  EXPECT_THAT(log, HasSubstr("has no instruction.instruction_text"));
}

// --by-decision: each choice against the goal oracle's verdict, worked out
// by hand
TEST(FailureStagesScriptTest, ChoicesAgainstTheOracleByDecision) {
  if (!vln::test::havePython()) GTEST_SKIP() << "no /usr/bin/python3";
  vln::test::TempDir dir;
  const std::vector<std::vector<double>> walked{{0, 0, 0}, {1, 0, 0}};
  const nlohmann::json candidates = {{1, 0, 0}, {0, 0, 1}};
  auto decided = [&](int id, const std::vector<nlohmann::json>& choices) {
    nlohmann::json e = episode(id, 0, 0, walked, kAlongPath, {1, 0});
    e["waypoint_choices"] = choices;
    return e;
  };
  // chosen, the oracle's choice, the end distances (null: unreachable)
  auto choice = [&](int chosen, int oracle, nlohmann::json ends) {
    return nlohmann::json{{"position", {0, 0, 0}},
                          {"candidates", candidates},
                          {"chosen", chosen},
                          {"oracle", oracle},
                          {"end_distances", ends}};
  };
  // 1: the oracle's choice, then a candidate 0.3 m worse (as good), then
  //    STOP with the oracle: never slips
  // 2: a candidate 1 m worse at decision 1 (a slip), then the oracle's
  // 3: the oracle's choice, then STOP where the oracle walks on
  // 4: walks on where the oracle STOPs, at decision 1
  writeRun(dir / "w",
           {decided(1, {choice(0, 0, {2.0, 3.0}), choice(1, 0, {2.0, 2.3}),
                        choice(-1, -1, nlohmann::json::array())}),
            decided(2, {choice(1, 0, {2.0, 3.0}), choice(0, 0, {1.0, 3.0})}),
            decided(3, {choice(0, 0, {2.0, 3.0}), choice(-1, 1, {3.0, 1.0})}),
            decided(4, {choice(0, -1, {2.0, nullptr})})});
  std::string log;
  ASSERT_EQ(runScript("--json --by-decision --split val_unseen --agent W '" +
                          (dir / "w").string() + "'",
                      &log),
            0)
      << log;
  const nlohmann::json w = nlohmann::json::parse(log).at("W");
  EXPECT_EQ(w.at("episodes").get<int>(), 4);
  const nlohmann::json rows = w.at("decisions");
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].at("reached").get<int>(), 4);
  EXPECT_DOUBLE_EQ(rows[0].at("as good").get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(rows[0].at("oracle choice").get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(rows[0].at("first slip").get<double>(), 0.5);
  EXPECT_EQ(rows[1].at("reached").get<int>(), 3);
  EXPECT_NEAR(rows[1].at("as good").get<double>(), 2.0 / 3, 1e-12);
  EXPECT_NEAR(rows[1].at("oracle choice").get<double>(), 1.0 / 3, 1e-12);
  EXPECT_DOUBLE_EQ(rows[1].at("first slip").get<double>(), 0.25);
  EXPECT_DOUBLE_EQ(rows[2].at("as good").get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(w.at("never slipped").get<double>(), 0.25);
  const nlohmann::json kinds = w.at("first slips");
  EXPECT_NEAR(kinds.at("worse candidate").get<double>(), 1.0 / 3, 1e-12);
  EXPECT_NEAR(kinds.at("stopped early").get<double>(), 1.0 / 3, 1e-12);
  EXPECT_NEAR(kinds.at("walked on").get<double>(), 1.0 / 3, 1e-12);
  // a tighter tolerance makes episode 1's second choice a slip
  ASSERT_EQ(runScript("--json --by-decision --tolerance 0.1 --split "
                      "val_unseen --agent W '" +
                          (dir / "w").string() + "'",
                      &log),
            0)
      << log;
  EXPECT_DOUBLE_EQ(
      nlohmann::json::parse(log).at("W").at("never slipped").get<double>(),
      0.0);
  // the table prints too
  ASSERT_EQ(runScript("--by-decision --split val_unseen --agent W '" +
                          (dir / "w").string() + "'",
                      &log),
            0)
      << log;
  EXPECT_THAT(log, HasSubstr("| W | never slipped | 4 | | | 0.250 |"));

  // files without the oracle's verdict (a hidden test split, an older
  // eval) are named, as is a negative tolerance
  nlohmann::json old = decided(1, {choice(0, 0, {2.0, 3.0})});
  old["waypoint_choices"][0].erase("oracle");
  writeRun(dir / "old", {old});
  EXPECT_NE(runScript("--by-decision --split val_unseen --agent W '" +
                          (dir / "old").string() + "'",
                      &log),
            0);
  EXPECT_THAT(log, HasSubstr("has no 'oracle' and 'end_distances'"));
  EXPECT_NE(runScript("--by-decision --tolerance -1 --split val_unseen "
                      "--agent W '" +
                          (dir / "w").string() + "'",
                      &log),
            0);
  EXPECT_THAT(log, HasSubstr("--tolerance must be >= 0"));
}

TEST(FailureStagesScriptTest, InputsItCannotUseAreNamed) {
  if (!vln::test::havePython()) GTEST_SKIP() << "no /usr/bin/python3";
  vln::test::TempDir dir;
  writeSplit(dir / "data");
  const std::vector<std::vector<double>> walked{{0, 0, 0}, {1, 0, 0}};
  const std::string common =
      "--data " + (dir / "data").string() + " --split val_unseen --agent A ";
  std::string log;
  EXPECT_NE(runScript(common + "'" + (dir / "nothing*").string() + "'", &log),
            0);
  EXPECT_THAT(log, HasSubstr("no directory matches"));
  // an episode the split does not have
  writeRun(dir / "extra", {episode(9, 1, 1, walked, kAlongPath, {1, 0})});
  EXPECT_NE(runScript(common + "'" + (dir / "extra").string() + "'", &log), 0);
  EXPECT_THAT(log, HasSubstr("episode 9 is not in split val_unseen"));
  // headings that do not match the positions
  nlohmann::json bad = episode(1, 1, 1, walked, kAlongPath, {1, 0});
  bad["path"]["headings"] = {0.0};
  writeRun(dir / "bad", {bad});
  EXPECT_NE(runScript(common + "'" + (dir / "bad").string() + "'", &log), 0);
  EXPECT_THAT(log, HasSubstr("episode 1 lacks"));
  EXPECT_THAT(log, HasSubstr((dir / "bad").string()));
  // a radius that passes nothing
  EXPECT_NE(runScript("--radius 0 " + common + "'" + (dir / "extra").string() +
                          "'",
                      &log),
            0);
  EXPECT_THAT(log, HasSubstr("--radius must be positive"));
  // a split whose reference path is a single point
  const nlohmann::json onePoint = {
      {"episode_id", 1},
      {"reference_path", nlohmann::json::array({{0, 0, 0}})}};
  common::writeJsonFile(dir / "short" / "val_unseen" / "val_unseen.json.gz",
                        {{"episodes", nlohmann::json::array({onePoint})}});
  EXPECT_NE(runScript("--data " + (dir / "short").string() +
                          " --split val_unseen --agent A '" +
                          (dir / "bad").string() + "'",
                      &log),
            0);
  EXPECT_THAT(log, HasSubstr("episode 1 has no reference_path"));
}

}  // namespace
}  // namespace vln::eval
