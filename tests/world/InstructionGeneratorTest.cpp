#include "world/InstructionGenerator.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "common/Json.h"
#include "data/Vocabulary.h"
#include "support/TestPaths.h"
#include "world/HouseGenerator.h"
#include "world/InstructionTestHouse.h"

namespace vln::world {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

using test::bedroomToKitchen;
using test::door;
using test::object;
using test::room;
using test::threeRooms;

std::string lower(std::string s) {
  for (char& c : s)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool containsWord(const std::string& text, const std::string& word) {
  const auto tokens = data::tokenize(text);
  return std::find(tokens.begin(), tokens.end(), word) != tokens.end();
}

// Independent grounding check: some point of the path polyline within
// `reach` of the object's footprint has the object's centre on `side` of
// the direction of travel.
bool passedOnSide(const std::vector<Vec3f>& path, const sim::SemanticObject& o,
                  Side side, float reach) {
  for (size_t i = 0; i + 1 < path.size(); ++i) {
    const Vec3f d = path[i + 1] - path[i];
    const float length = std::hypot(d.x(), d.z());
    if (length < 1e-4f) continue;
    const Vec3f forward(d.x() / length, 0.0f, d.z() / length);
    // left of forward, seen from above with +Y up
    const Vec3f left(forward.z(), 0.0f, -forward.x());
    for (int k = 0; k <= 50; ++k) {
      const Vec3f p = path[i] + (static_cast<float>(k) / 50.0f) * d;
      if (footprintDistance(o.bounds, p) > reach) continue;
      const Vec3f c = o.bounds.center() - p;
      const float lateral = c.x() * left.x() + c.z() * left.z();
      if (side == Side::kNone) return true;
      if ((side == Side::kLeft) == (lateral > 0.0f)) return true;
    }
  }
  return false;
}

float distanceToPath(const std::vector<Vec3f>& path,
                     const sim::SemanticObject& o) {
  float best = 1e9f;
  for (size_t i = 0; i + 1 < path.size(); ++i)
    for (int k = 0; k <= 50; ++k)
      best = std::min(
          best, footprintDistance(o.bounds,
                                  path[i] + (static_cast<float>(k) / 50.0f) *
                                                (path[i + 1] - path[i])));
  return best;
}

const sim::SemanticObject& objectById(const sim::SceneSemantics& s, int id) {
  const auto* o = s.object(id);
  EXPECT_NE(o, nullptr) << "unknown object id " << id;
  return *o;
}

// ---------------------------------------------------------------------------
// tests
// ---------------------------------------------------------------------------

// The human-style instructions (three per seed, seeds 0 to seeds - 1) of
// `path` from `heading` in one empty 20 x 20 m office: turns are all there
// is to describe.
std::vector<GeneratedInstruction> inEmptyOffice(const std::vector<Vec3f>& path,
                                                float heading, uint64_t seeds) {
  sim::SceneSemantics empty;
  empty.rooms = {room(0, "office", -10, -10, 10, 10)};
  const InstructionGenerator generator(empty, InstructionConfig{});
  std::vector<GeneratedInstruction> all;
  for (uint64_t seed = 0; seed < seeds; ++seed)
    for (auto& g :
         generator.generate(path, heading, InstructionStyle::kHuman, 3, seed))
      all.push_back(std::move(g));
  return all;
}

TEST(InstructionGeneratorTest, LeftTurnSaysLeftRightTurnSaysRight) {
  // facing -Z, walk 4 m along -Z, then turn to -X: a left turn (+90 deg)
  const std::vector<Vec3f> left = {{0, 0, 0}, {0, 0, -4}, {-4, 0, -4}};
  const std::vector<Vec3f> right = {{0, 0, 0}, {0, 0, -4}, {4, 0, -4}};
  for (const auto& g : inEmptyOffice(left, 0.0f, 30)) {
    EXPECT_TRUE(containsWord(g.text, "left")) << g.text;
    EXPECT_FALSE(containsWord(g.text, "right")) << g.text;
  }
  for (const auto& g : inEmptyOffice(right, 0.0f, 30)) {
    EXPECT_TRUE(containsWord(g.text, "right")) << g.text;
    EXPECT_FALSE(containsWord(g.text, "left")) << g.text;
  }
}

// The text between and around the clauses of `g` joins them and nothing
// more; the spans are in text order, and their legs do not go back.
void expectClausesCoverTheText(const GeneratedInstruction& g, int stopLeg) {
  static const std::set<std::string> kJoins = {
      "", "and", "then", "next", "after that", "now", "from there", "and then"};
  ASSERT_FALSE(g.sub_instructions.empty()) << g.text;
  size_t at = 0;
  int leg = 0;
  auto expectJoin = [&](size_t begin, size_t end) {
    std::string gap = lower(g.text.substr(begin, end - begin));
    std::erase_if(gap, [](char c) { return c == '.' || c == ','; });
    while (!gap.empty() && gap.front() == ' ') gap.erase(gap.begin());
    while (!gap.empty() && gap.back() == ' ') gap.pop_back();
    EXPECT_TRUE(kJoins.count(gap)) << "'" << gap << "' in " << g.text;
  };
  for (const data::SubInstruction& s : g.sub_instructions) {
    ASSERT_GE(static_cast<size_t>(s.begin), at) << g.text;
    ASSERT_LT(s.begin, s.end) << g.text;
    ASSERT_LE(static_cast<size_t>(s.end), g.text.size()) << g.text;
    expectJoin(at, static_cast<size_t>(s.begin));
    EXPECT_GE(s.leg, leg) << g.text;
    leg = s.leg;
    at = static_cast<size_t>(s.end);
  }
  expectJoin(at, g.text.size());
  EXPECT_EQ(g.sub_instructions.back().leg, stopLeg) << g.text;
  const std::string stop = lower(
      g.text.substr(static_cast<size_t>(g.sub_instructions.back().begin), 4));
  EXPECT_TRUE(stop == "stop" || stop == "wait" || stop == "stan") << g.text;
}

TEST(InstructionGeneratorTest, SubInstructionsAreTheClausesWithTheirLegs) {
  // a left turn at waypoint 1 (the agent starts facing the first leg): the
  // clause saying "left" describes leg 1
  const std::vector<Vec3f> left = {{0, 0, 0}, {0, 0, -4}, {-4, 0, -4}};
  for (const auto& g : inEmptyOffice(left, 0.0f, 30)) {
    expectClausesCoverTheText(g, 2);
    for (const data::SubInstruction& s : g.sub_instructions) {
      const std::string clause = g.text.substr(
          static_cast<size_t>(s.begin), static_cast<size_t>(s.end - s.begin));
      if (containsWord(clause, "left")) {
        EXPECT_EQ(s.leg, 1) << g.text;
      }
    }
  }
  // landmarks and rooms, both styles
  const sim::SceneSemantics semantics = threeRooms();
  const InstructionGenerator generator(semantics, InstructionConfig{});
  const auto path = bedroomToKitchen();
  for (uint64_t seed = 0; seed < 40; ++seed)
    for (const InstructionStyle style :
         {InstructionStyle::kHuman, InstructionStyle::kSpeaker})
      for (const auto& g : generator.generate(path, 1.0f, style, 3, seed))
        expectClausesCoverTheText(g, static_cast<int>(path.size()) - 1);
}

TEST(InstructionGeneratorTest, DoublingBackIsASharpTurn) {
  // along -Z, then back towards +Z and -X: a 150 degree left turn
  const float back = degToRad(150.0f);
  const Vec3f corner(0, 0, -4);
  const std::vector<Vec3f> path = {
      {0, 0, 0}, corner, corner + 4.0f * headingToForward(back)};
  for (const auto& g : inEmptyOffice(path, 0.0f, 20)) {
    EXPECT_TRUE(containsWord(g.text, "sharp") ||
                containsWord(g.text, "sharply"))
        << g.text;
    EXPECT_TRUE(containsWord(g.text, "left")) << g.text;
    EXPECT_FALSE(containsWord(g.text, "around")) << g.text;
  }
}

TEST(InstructionGeneratorTest, StartFacingAwayTurnsAround) {
  const std::vector<Vec3f> path = {{0, 0, 0}, {0, 0, -4}, {0, 0, -8}};
  // heading pi looks along +Z, away from the path
  for (const auto& g : inEmptyOffice(path, kPi, 20))
    EXPECT_TRUE(containsWord(g.text, "around")) << g.text;
  // facing the path: no turn is mentioned
  for (const auto& g : inEmptyOffice(path, 0.0f, 20)) {
    EXPECT_FALSE(containsWord(g.text, "around")) << g.text;
    EXPECT_FALSE(containsWord(g.text, "left")) << g.text;
  }
}

TEST(InstructionGeneratorTest, MentionsAreGrounded) {
  const sim::SceneSemantics semantics = threeRooms();
  const InstructionConfig config;
  const InstructionGenerator generator(semantics, config);
  const auto path = bedroomToKitchen();
  std::map<LandmarkRole, int> roles;
  int sided = 0;
  for (uint64_t seed = 0; seed < 60; ++seed) {
    for (const auto& g :
         generator.generate(path, 1.0f, InstructionStyle::kHuman, 3, seed)) {
      EXPECT_EQ(g.goal_room, 2) << "the goal is in the kitchen";
      const std::string text = lower(g.text);
      for (const LandmarkMention& m : g.landmarks) {
        const auto& o = objectById(semantics, m.object_id);
        ++roles[m.role];
        EXPECT_TRUE(m.truthful);
        EXPECT_THAT(text, HasSubstr(m.phrase)) << g.text;
        // a stated colour is the object's own
        const auto space = m.phrase.find(' ');
        if (space != std::string::npos &&
            m.phrase.substr(space + 1) != "plant" &&
            m.phrase.substr(space + 1) != "counter" &&
            m.phrase.substr(space + 1) != "lamp") {
          const std::string color = m.phrase.substr(0, space);
          const bool same =
              color == o.color || (o.color == "wooden" && color == "wood");
          EXPECT_TRUE(same)
              << m.phrase << " for a " << o.color << " " << o.category;
        }
        switch (m.role) {
          case LandmarkRole::kPass:
          case LandmarkRole::kBetween:
            EXPECT_TRUE(
                passedOnSide(path, o, m.side, config.landmark_distance + 0.05f))
                << g.text << " -- " << m.phrase;
            if (m.side != Side::kNone) ++sided;
            break;
          case LandmarkRole::kToward:
            EXPECT_LE(distanceToPath(path, o),
                      config.landmark_distance + 0.05f);
            break;
          case LandmarkRole::kTurnAt:
            ASSERT_GE(m.leg, 0);
            EXPECT_LE(
                footprintDistance(o.bounds, path[static_cast<size_t>(m.leg)]),
                1.25f);
            break;
          case LandmarkRole::kStop:
            EXPECT_LE(footprintDistance(o.bounds, path.back()),
                      config.stop_landmark_distance + 1e-4f);
            EXPECT_EQ(o.room, 2);
            break;
        }
      }
    }
  }
  // the path passes the red bed, the plant, the table; it ends at the fridge
  EXPECT_GT(roles[LandmarkRole::kPass], 20);
  EXPECT_GT(roles[LandmarkRole::kStop], 100);
  EXPECT_GT(sided, 10);
}

// The same grounding checks on generated houses (windows, pictures, rugs,
// many rooms): routes from each room's centre through two doorways.
TEST(InstructionGeneratorTest, MentionsAreGroundedInGeneratedHouses) {
  const InstructionConfig config;
  int mentions = 0;
  for (uint64_t seed : {1u, 2u, 3u}) {
    const House house = generateHouse(seed, HouseConfig{});
    const auto& s = house.semantics;
    const InstructionGenerator generator(s, config);
    auto center = [&](int r) {
      const Vec2f c = s.rooms[static_cast<size_t>(r)].footprint.center();
      return Vec3f(c.x(), s.rooms[static_cast<size_t>(r)].floor_y, c.y());
    };
    for (int start = 0; start < static_cast<int>(s.rooms.size()); ++start) {
      std::vector<Vec3f> path = {center(start)};
      int room = start;
      int previous = -1;
      for (int hop = 0; hop < 2; ++hop) {
        const sim::Doorway* through = nullptr;
        for (const auto& d : s.doors) {
          const int other = d.room_a == room   ? d.room_b
                            : d.room_b == room ? d.room_a
                                               : -1;
          if (other >= 0 && other != previous) {
            through = &d;
            previous = room;
            room = other;
            break;
          }
        }
        if (through == nullptr) break;
        path.push_back(through->center);
        path.push_back(center(room));
      }
      if (path.size() < 3) continue;
      for (const auto& g :
           generator.generate(path, 0.0f, InstructionStyle::kHuman, 3, seed)) {
        EXPECT_EQ(g.goal_room, s.roomAt(path.back())) << g.text;
        for (const LandmarkMention& m : g.landmarks) {
          const auto& o = objectById(s, m.object_id);
          EXPECT_THAT(lower(g.text), HasSubstr(m.phrase));
          ++mentions;
          switch (m.role) {
            case LandmarkRole::kPass:
            case LandmarkRole::kBetween:
              EXPECT_TRUE(passedOnSide(path, o, m.side,
                                       config.landmark_distance + 0.05f))
                  << g.text << " -- " << m.phrase;
              break;
            case LandmarkRole::kToward:
              EXPECT_LE(distanceToPath(path, o),
                        config.landmark_distance + 0.05f);
              break;
            case LandmarkRole::kTurnAt:
              EXPECT_LE(
                  footprintDistance(o.bounds, path[static_cast<size_t>(m.leg)]),
                  1.25f);
              break;
            case LandmarkRole::kStop:
              EXPECT_LE(footprintDistance(o.bounds, path.back()),
                        config.stop_landmark_distance + 1e-4f);
              EXPECT_EQ(o.room, g.goal_room);
              break;
          }
        }
      }
    }
  }
  EXPECT_GT(mentions, 50);
}

TEST(InstructionGeneratorTest, PassedSidesMatchTheGeometry) {
  // a straight corridor along -Z with a sofa on the left (-X) and a tv on
  // the right (+X)
  sim::SceneSemantics s;
  s.rooms = {room(0, "living room", -3, -12, 3, 0)};
  s.objects = {
      object(1, "sofa", "blue", 0, {-2.2f, 0, -6.5f}, {-1.0f, 0.8f, -4.5f}),
      object(2, "tv", "black", 0, {1.2f, 0.5f, -6.0f}, {1.5f, 1.2f, -5.0f})};
  InstructionConfig config;
  config.detail = 1.0f;
  const InstructionGenerator generator(s, config);
  const std::vector<Vec3f> path = {{0, 0, -1}, {0, 0, -5}, {0, 0, -10}};
  int checked = 0;
  for (uint64_t seed = 0; seed < 40; ++seed) {
    for (const auto& g :
         generator.generate(path, 0.0f, InstructionStyle::kHuman, 3, seed)) {
      for (const auto& m : g.landmarks) {
        if (m.role != LandmarkRole::kPass || m.side == Side::kNone) continue;
        EXPECT_EQ(m.side, m.object_id == 1 ? Side::kLeft : Side::kRight)
            << g.text;
        const std::string said = m.side == Side::kLeft ? "left" : "right";
        EXPECT_THAT(lower(g.text), HasSubstr(m.phrase));
        EXPECT_TRUE(containsWord(g.text, said)) << g.text;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 20);
}

TEST(InstructionGeneratorTest, InstructionsOfAPathDifferAndAreDeterministic) {
  const sim::SceneSemantics semantics = threeRooms();
  const InstructionGenerator generator(semantics, InstructionConfig{});
  const auto path = bedroomToKitchen();
  for (uint64_t seed = 0; seed < 20; ++seed) {
    const auto a =
        generator.generate(path, 0.3f, InstructionStyle::kHuman, 3, seed);
    const auto b =
        generator.generate(path, 0.3f, InstructionStyle::kHuman, 3, seed);
    ASSERT_EQ(a.size(), 3u);
    std::set<std::string> texts;
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].text, b[i].text);
      texts.insert(a[i].text);
    }
    EXPECT_EQ(texts.size(), 3u) << a[0].text;
  }
  const auto c = generator.generate(path, 0.3f, InstructionStyle::kHuman, 1, 1);
  const auto d = generator.generate(path, 0.3f, InstructionStyle::kHuman, 1, 2);
  EXPECT_NE(c[0].text, d[0].text);
}

TEST(InstructionGeneratorTest, HumanLengthIsRoomToRoomLike) {
  const sim::SceneSemantics semantics = threeRooms();
  const InstructionGenerator generator(semantics, InstructionConfig{});
  // five nodes, about 11 m: an R2R-sized path
  const std::vector<Vec3f> path = {{2.0f, 0.0f, 3.2f},
                                   {5.0f, 0.0f, 2.5f},
                                   {6.0f, 0.0f, 5.0f},
                                   {5.0f, 0.0f, 7.5f},
                                   {1.5f, 0.0f, 8.6f}};
  double words = 0;
  int n = 0;
  double speakerWords = 0;
  int m = 0;
  for (uint64_t seed = 0; seed < 50; ++seed) {
    for (const auto& g :
         generator.generate(path, 2.0f, InstructionStyle::kHuman, 3, seed)) {
      words += static_cast<double>(data::tokenize(g.text).size());
      ++n;
    }
    for (const auto& g :
         generator.generate(path, 2.0f, InstructionStyle::kSpeaker, 1, seed)) {
      speakerWords += static_cast<double>(data::tokenize(g.text).size());
      ++m;
    }
  }
  // R2R: 29 words on average (Anderson et al. 2018); punctuation tokens
  // count here as in the tokenised files
  EXPECT_GT(words / n, 18.0);
  EXPECT_LT(words / n, 45.0);
  EXPECT_LT(speakerWords / m, words / n) << "the speaker style is shorter";
}

TEST(InstructionGeneratorTest,
     SpeakerStyleIsLowercaseAndItsMistakesAreFlagged) {
  const sim::SceneSemantics semantics = threeRooms();
  InstructionConfig noisy;
  noisy.speaker_wrong_side = 1.0f;
  noisy.speaker_wrong_color = 1.0f;
  noisy.speaker_drop_landmark = 0.0f;
  const InstructionGenerator generator(semantics, noisy);
  const auto path = bedroomToKitchen();
  int wrong = 0;
  for (uint64_t seed = 0; seed < 30; ++seed) {
    for (const auto& g :
         generator.generate(path, 0.0f, InstructionStyle::kSpeaker, 1, seed)) {
      EXPECT_EQ(g.text, lower(g.text));
      EXPECT_THAT(g.text, HasSubstr(" ."));
      for (const auto& m : g.landmarks) {
        EXPECT_FALSE(m.truthful) << g.text << " -- " << m.phrase;
        if (m.role == LandmarkRole::kPass && m.side != Side::kNone) {
          const auto& o = objectById(semantics, m.object_id);
          // flipped: the stated side is never where the object is
          EXPECT_FALSE(passedOnSide(path, o, m.side, 0.6f)) << m.phrase;
        }
        ++wrong;
      }
    }
  }
  EXPECT_GT(wrong, 10);

  InstructionConfig clean = noisy;
  clean.speaker_wrong_side = 0.0f;
  clean.speaker_wrong_color = 0.0f;
  const InstructionGenerator honest(semantics, clean);
  for (uint64_t seed = 0; seed < 30; ++seed)
    for (const auto& g :
         honest.generate(path, 0.0f, InstructionStyle::kSpeaker, 1, seed))
      for (const auto& m : g.landmarks) EXPECT_TRUE(m.truthful) << g.text;
}

TEST(InstructionGeneratorTest, ShortPathIsRejected) {
  const sim::SceneSemantics semantics = threeRooms();
  const InstructionGenerator generator(semantics, InstructionConfig{});
  EXPECT_THROW(
      generator.generate({{0, 0, 0}}, 0.0f, InstructionStyle::kHuman, 1, 0),
      std::invalid_argument);
}

// Every room type, object category and colour the house generator uses,
// walked through: >= 95% of the tokens must be words of the real R2R
// vocabulary.
TEST(InstructionGeneratorTest, WordsComeFromTheRoomToRoomVocabulary) {
  const auto file = test::realR2rSample("val_seen_sample.json.gz");
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "no fixture " << file;
  const auto json = common::readJsonFile(file);
  const auto words = json.at("instruction_vocab")
                         .at("word_list")
                         .get<std::vector<std::string>>();
  const std::set<std::string> vocabulary(words.begin(), words.end());

  // one room per type in a row along -Z, objects of every category and
  // colour beside the path
  const auto& types = houseRoomTypes();
  const auto& categories = houseObjectCategories();
  const auto& colors = houseColorNames();
  sim::SceneSemantics s;
  std::vector<Vec3f> path;
  for (size_t r = 0; r < types.size(); ++r) {
    const float z0 = -6.0f * static_cast<float>(r + 1);
    s.rooms.push_back(
        room(static_cast<int>(r), types[r].c_str(), -4, z0, 4, z0 + 6));
    if (r > 0)
      s.doors.push_back(door(static_cast<int>(r) - 1, static_cast<int>(r),
                             {0.0f, 0.0f, z0 + 6}, Vec3f::UnitZ()));
    path.push_back({r % 2 ? 1.0f : -1.0f, 0.0f, z0 + 3.0f});
  }
  for (size_t c = 0; c < categories.size(); ++c) {
    const size_t r = c % types.size();
    const float z = -6.0f * static_cast<float>(r + 1) + 1.0f +
                    0.8f * static_cast<float>(c / types.size());
    const float x = c % 2 ? 2.0f : -2.5f;
    s.objects.push_back(object(static_cast<int>(c), categories[c].c_str(),
                               colors[c % colors.size()].c_str(),
                               static_cast<int>(r), {x, 0.0f, z},
                               {x + 0.5f, 0.8f, z + 0.5f}));
  }
  InstructionConfig config;
  config.detail = 1.0f;
  const InstructionGenerator generator(s, config);
  int64_t known = 0;
  int64_t total = 0;
  std::map<std::string, int> unknown;
  for (uint64_t seed = 0; seed < 40; ++seed) {
    for (const auto style :
         {InstructionStyle::kHuman, InstructionStyle::kSpeaker}) {
      for (size_t start = 0; start + 2 < path.size(); ++start) {
        const std::vector<Vec3f> sub(
            path.begin() + static_cast<long>(start),
            path.begin() + static_cast<long>(std::min(path.size(), start + 4)));
        for (const auto& g : generator.generate(sub, 0.5f, style, 3, seed)) {
          for (const auto& token : data::tokenize(g.text)) {
            ++total;
            if (vocabulary.count(token))
              ++known;
            else
              ++unknown[token];
          }
        }
      }
    }
  }
  ASSERT_GT(total, 1000);
  std::string missing;
  for (const auto& [word, count] : unknown)
    missing += word + "(" + std::to_string(count) + ") ";
  EXPECT_GE(static_cast<double>(known) / static_cast<double>(total), 0.95)
      << "out-of-vocabulary tokens: " << missing;
}

}  // namespace
}  // namespace vln::world
