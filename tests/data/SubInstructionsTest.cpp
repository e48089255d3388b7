// Tests src/data/SubInstructions.cpp: the sub-instruction file, its checks
// against the episodes, token ranges and the leg ahead of a position.

#include "data/SubInstructions.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <functional>

#include "common/FileIo.h"
#include "common/Json.h"
#include "data/Vocabulary.h"
#include "support/TestPaths.h"

namespace vln::data {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

const std::string kText = "Turn left, then walk past the sofa. Stop by the tv.";

Episode episode(int id) {
  Episode e;
  e.episode_id = id;
  e.instruction.instruction_text = kText;
  e.reference_path = {Vec3f(0, 0, 0), Vec3f(0, 0, -2), Vec3f(2, 0, -2)};
  return e;
}

SubInstructions subInstructions() {
  // "Turn left" [0, 9), "walk past the sofa" [16, 34), "Stop by the tv"
  // [36, 50) of 51 bytes
  return {{1, {{0, 9, 0}, {16, 34, 1}, {36, 50, 2}}}, {2, {}}};
}

TEST(SubInstructionsTest, RoundTripsThroughGzip) {
  test::TempDir dir;
  const std::filesystem::path file =
      splitSubInstructionsPath(dir.path(), "train");
  EXPECT_EQ(file, dir.path() / "train" / "train_sub_instructions.json.gz");
  writeSubInstructions(file, subInstructions());
  EXPECT_EQ(readSubInstructions(file), subInstructions());
  EXPECT_EQ(common::readJsonFile(file)["1"][1],
            (nlohmann::json{{"begin", 16}, {"end", 34}, {"leg", 1}}));
}

TEST(SubInstructionsTest, ErrorsNameFileEpisodeAndField) {
  struct Case {
    std::string name;
    std::function<void(nlohmann::json&)> corrupt;
    std::vector<std::string> expected;
  };
  const std::vector<Case> cases = {
      {"not an object",
       [](nlohmann::json& j) { j = nlohmann::json::array(); },
       {"expected a JSON object keyed by episode id"}},
      {"key not an id",
       [](nlohmann::json& j) { j["one"] = j["1"]; },
       {"key 'one' is not an integer episode id"}},
      {"entry not an array",
       [](nlohmann::json& j) { j["1"] = 3; },
       {"episode 1", "expected an array of sub-instructions"}},
      {"missing leg",
       [](nlohmann::json& j) { j["1"][2].erase("leg"); },
       {"episode 1", "sub-instruction 2", "field 'leg' is missing"}},
      {"fractional begin",
       [](nlohmann::json& j) { j["1"][0]["begin"] = 1.5; },
       {"episode 1", "sub-instruction 0", "'begin' must be an integer"}},
      {"negative leg",
       [](nlohmann::json& j) { j["1"][1]["leg"] = -1; },
       {"episode 1", "sub-instruction 1", "'leg' must be in [0"}},
      {"end before begin",
       [](nlohmann::json& j) { j["1"][1]["end"] = 3; },
       {"episode 1", "sub-instruction 1", "'end' (3) is before 'begin' (16)"}},
  };
  test::TempDir dir;
  nlohmann::json good;
  {
    writeSubInstructions(dir.path() / "good.json", subInstructions());
    good = common::readJsonFile(dir.path() / "good.json");
  }
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    nlohmann::json bad = good;
    c.corrupt(bad);
    common::writeJsonFile(dir.path() / "bad_sub.json.gz", bad);
    try {
      readSubInstructions(dir.path() / "bad_sub.json.gz");
      ADD_FAILURE() << "no exception";
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr("bad_sub.json.gz"));
      for (const std::string& part : c.expected)
        EXPECT_THAT(e.what(), HasSubstr(part));
    }
  }
  EXPECT_THROW(readSubInstructions(dir.path() / "missing.json.gz"),
               std::runtime_error);
  // the writer refuses what the reader would, leaving no file
  SubInstructions bad = subInstructions();
  bad[1][0].end = -1;
  EXPECT_THAT([&] { writeSubInstructions(dir.path() / "w.json.gz", bad); },
              ThrowsMessage<std::invalid_argument>(HasSubstr("episode 1")));
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "w.json.gz"));
}

TEST(SubInstructionsTest, ChecksSpansAndLegsAgainstTheEpisodes) {
  const std::vector<Episode> episodes{episode(1), episode(2)};
  EXPECT_NO_THROW(checkSubInstructions(subInstructions(), episodes, "f"));

  SubInstructions missing = subInstructions();
  missing.erase(2);
  EXPECT_THAT([&] { checkSubInstructions(missing, episodes, "f.json"); },
              ThrowsMessage<std::invalid_argument>(
                  HasSubstr("f.json: episode 2 has no sub-instructions")));
  SubInstructions longSpan = subInstructions();
  longSpan[1][2].end = 52;
  EXPECT_THAT([&] { checkSubInstructions(longSpan, episodes, "f.json"); },
              ThrowsMessage<std::invalid_argument>(HasSubstr(
                  "episode 1: sub-instruction 2: field 'end' (52) is beyond "
                  "the instruction_text's 51 bytes")));
  SubInstructions farLeg = subInstructions();
  farLeg[1][2].leg = 3;
  EXPECT_THAT([&] { checkSubInstructions(farLeg, episodes, "f.json"); },
              ThrowsMessage<std::invalid_argument>(
                  HasSubstr("field 'leg' (3) is beyond the reference_path's "
                            "last point (2)")));
}

TEST(SubInstructionsTest, TokenRangesFollowTheTokeniser) {
  // tokenize(): turn left then walk past the sofa . stop by the tv .
  ASSERT_EQ(tokenize(kText).size(), 13u);
  const auto ranges = subInstructionTokens(kText, subInstructions().at(1));
  ASSERT_EQ(ranges.size(), 3u);
  EXPECT_EQ(ranges[0].first, 0);
  EXPECT_EQ(ranges[0].last, 2);  // turn left
  EXPECT_EQ(ranges[1].first, 3);
  EXPECT_EQ(ranges[1].last, 7);  // walk past the sofa
  EXPECT_EQ(ranges[2].first, 8);
  EXPECT_EQ(ranges[2].last, 12);  // stop by the tv
  EXPECT_EQ(ranges[2].leg, 2);
  const auto words = tokenize(kText);
  EXPECT_EQ(words[3], "walk");
  EXPECT_EQ(words[11], "tv");
  // offsets past the text are clamped to it
  const auto clamped = subInstructionTokens(kText, {{40, 400, 0}});
  EXPECT_EQ(clamped[0].last, 13);
}

TEST(SubInstructionsTest, UpcomingLegLooksAheadAlongTheNearestSegment) {
  // leg 0 from (0,0,0) to (0,0,-2), leg 1 to (2,0,-2); 2 = the stop
  const std::vector<Vec3f> path = episode(1).reference_path;
  EXPECT_EQ(upcomingLeg(path, Vec3f(0, 0, 0), 0.5f), 0);
  EXPECT_EQ(upcomingLeg(path, Vec3f(0.1f, 0, -1.0f), 0.5f), 0);
  // 0.3 m short of the turn: half a metre on is the second leg
  EXPECT_EQ(upcomingLeg(path, Vec3f(0, 0, -1.7f), 0.5f), 1);
  EXPECT_EQ(upcomingLeg(path, Vec3f(0, 0, -1.7f), 0.0f), 0);
  EXPECT_EQ(upcomingLeg(path, Vec3f(1.0f, 0, -2.2f), 0.5f), 1);
  // near the end the stop
  EXPECT_EQ(upcomingLeg(path, Vec3f(1.7f, 0, -2.0f), 0.5f), 2);
  EXPECT_EQ(upcomingLeg(path, Vec3f(5.0f, 0, -2.0f), 0.0f), 2);
  EXPECT_THROW(upcomingLeg({Vec3f::Zero()}, Vec3f::Zero(), 0.5f),
               std::invalid_argument);
}

// the clauses of the leg ahead, or of the next leg a clause describes when
// the one ahead has none (a straight leg left unsaid)
TEST(SubInstructionsTest, ClausesAheadAreThoseOfTheNextDescribedLeg) {
  const std::vector<Vec3f> path = episode(1).reference_path;  // legs 0, 1, 2
  const std::vector<SubInstructionTokens> clauses = {
      {0, 3, 0}, {3, 5, 0}, {5, 9, 2}};
  auto firstTokens = [&](const Vec3f& at) {
    std::vector<int> out;
    for (const SubInstructionTokens& c : clausesAhead(clauses, path, at))
      out.push_back(c.first);
    return out;
  };
  using ::testing::ElementsAre;
  EXPECT_THAT(firstTokens(Vec3f(0, 0, 0)), ElementsAre(0, 3));
  // leg 1 is left unsaid: its walker reads the stop's clause
  EXPECT_THAT(firstTokens(Vec3f(1.0f, 0, -2.2f)), ElementsAre(5));
  EXPECT_THAT(firstTokens(Vec3f(5.0f, 0, -2.0f)), ElementsAre(5));
  // nothing ahead, or no path to be along
  EXPECT_TRUE(clausesAhead({{0, 3, 0}}, path, Vec3f(5.0f, 0, -2.0f)).empty());
  EXPECT_TRUE(clausesAhead(clauses, {Vec3f::Zero()}, Vec3f::Zero()).empty());
}

// the rule's clauses: cut after punctuation and before "and" / "then"
// ("and then" once), as token ranges of tokenize()
TEST(SubInstructionsTest, RuleClausesCutAtPunctuationAndConnectives) {
  auto spans = [](std::string_view text) {
    std::vector<std::pair<int, int>> out;
    for (const SubInstructionTokens& c : ruleClauses(text)) {
      EXPECT_EQ(c.leg, static_cast<int>(out.size()));
      out.emplace_back(c.first, c.last);
    }
    return out;
  };
  using P = std::pair<int, int>;
  using ::testing::ElementsAre;
  // turn left | then walk past the sofa . | stop by the tv .
  EXPECT_THAT(spans(kText), ElementsAre(P(0, 2), P(2, 8), P(8, 13)));
  // "And then" cuts once; "sandy" and "Thence" are not connectives
  EXPECT_THAT(spans("Go up the stairs and then turn left; pass the sandy rug "
                    "Thence stop!"),
              ElementsAre(P(0, 4), P(4, 9), P(9, 16)));
  EXPECT_THAT(spans("walk and wait"), ElementsAre(P(0, 1), P(1, 3)));
  // no tokens, no clause
  EXPECT_TRUE(ruleClauses("").empty());
  EXPECT_TRUE(ruleClauses(" , ,").empty());
  // repeated punctuation is one token; a long text with a cut every few
  // bytes costs its length (a quadratic count would take minutes here)
  EXPECT_THAT(spans("Go on... then stop"), ElementsAre(P(0, 3), P(3, 5)));
  std::string longText;
  for (int i = 0; i < 200000; ++i) longText += "go, ";
  const auto many = ruleClauses(longText);
  ASSERT_EQ(many.size(), 200000u);
  EXPECT_EQ(many.back().first, 199999);
  EXPECT_EQ(many.back().last, 200000);
  const auto clauses = ruleClauses(kText);
  EXPECT_EQ(clauseHolding(clauses, 0), 0);
  EXPECT_EQ(clauseHolding(clauses, 7), 1);
  EXPECT_EQ(clauseHolding(clauses, 8), 2);
  EXPECT_EQ(clauseHolding(clauses, 99), 2);
  EXPECT_EQ(clauseHolding({}, 3), 0);
}

}  // namespace
}  // namespace vln::data
