// Tests of src/world/ViewLabels.cpp: a view's labels from a hand-made
// semantic render, and a panorama's labels on a generated house (their
// layout, the views' order as the agent turns, the room shared by all
// views), and the labels an instruction's goal clause names (goalLabels()).

#include "world/ViewLabels.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include "sim/Scene.h"
#include "world/HouseGenerator.h"

namespace vln::world {
namespace {

using ::testing::HasSubstr;

int64_t indexOf(const std::vector<std::string>& names,
                const std::string& name) {
  return std::find(names.begin(), names.end(), name) - names.begin();
}

// ---------------------------------------------------------------------------
// one view

TEST(LabelViewTest, ObjectsAboveTheFractionTheirColoursAndTheRoom) {
  sim::SceneSemantics s;
  sim::Room kitchen;
  kitchen.id = 0;
  kitchen.type = "kitchen";
  kitchen.footprint = Eigen::AlignedBox2f(Vec2f(0, 0), Vec2f(4, 4));
  sim::Room bedroom = kitchen;
  bedroom.id = 1;
  bedroom.type = "bedroom";
  bedroom.footprint = Eigen::AlignedBox2f(Vec2f(4, 0), Vec2f(8, 4));
  s.rooms = {kitchen, bedroom};
  auto object = [](int id, const char* category, const char* color) {
    sim::SemanticObject o;
    o.id = id;
    o.category = category;
    o.color = color;
    return o;
  };
  s.objects = {object(0, "bed", "blue"), object(1, "chair", "red"),
               object(2, "sofa", "red")};

  // 100 pixels: bed 10, chair 3, sofa 2 + 2 (split, still one object), rest
  // none
  std::vector<int32_t> ids(100, -1);
  std::fill(ids.begin(), ids.begin() + 10, 0);
  std::fill(ids.begin() + 10, ids.begin() + 13, 1);
  std::fill(ids.begin() + 20, ids.begin() + 22, 2);
  std::fill(ids.begin() + 50, ids.begin() + 52, 2);
  const auto& categories = houseObjectCategories();
  const auto& colors = houseColorNames();

  ViewLabels l =
      labelView(s, ids, Vec3f(5.0f, 0.0f, 1.0f), /*minFraction=*/0.04f);
  EXPECT_EQ(l.room, indexOf(houseRoomTypes(), "bedroom"));
  ASSERT_EQ(l.categories.size(), categories.size());
  ASSERT_EQ(l.colors.size(), colors.size());
  std::vector<uint8_t> expectCategories(categories.size(), 0),
      expectColors(colors.size(), 0);
  expectCategories[static_cast<size_t>(indexOf(categories, "bed"))] = 1;
  expectCategories[static_cast<size_t>(indexOf(categories, "sofa"))] =
      1;  // 4 pixels in two parts
  expectColors[static_cast<size_t>(indexOf(colors, "blue"))] = 1;
  expectColors[static_cast<size_t>(indexOf(colors, "red"))] = 1;  // the sofa's
  EXPECT_EQ(l.categories, expectCategories);
  EXPECT_EQ(l.colors, expectColors);

  // a lower threshold adds the chair; outside every room there is no room
  l = labelView(s, ids, Vec3f(9.0f, 0.0f, 1.0f), 0.03f);
  EXPECT_EQ(l.room, -1);
  EXPECT_EQ(l.categories[static_cast<size_t>(indexOf(categories, "chair"))], 1);

  // names outside the generator's vocabulary are data errors naming them
  s.objects[0].color = "mauve";
  try {
    labelView(s, ids, Vec3f(1.0f, 0.0f, 1.0f), 0.04f);
    FAIL() << "accepted an unknown colour";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("object 0"));
    EXPECT_THAT(e.what(), HasSubstr("'mauve'"));
  }
  ids[0] = 9;  // no object 9
  EXPECT_THROW(labelView(s, ids, Vec3f(1.0f, 0.0f, 1.0f), 0.0001f),
               std::invalid_argument);
}

// ---------------------------------------------------------------------------
// a panorama's labels

TEST(ViewLabelFeaturesTest, ViewsTurnWithTheAgentAndShareTheRoom) {
  HouseConfig config;
  config.min_rooms = 3;
  config.max_rooms = 4;
  House house = generateHouse(/*seed=*/11, config, "h11");
  const auto scene = sim::Scene::fromMesh("h11", house.mesh, house.semantics,
                                          sim::NavMeshConfig{});
  auto renderer = sim::createRenderer(scene->mesh(), scene->rayTracer(),
                                      sim::RendererBackend::kEmbree);
  sim::PanoramaConfig panorama;
  panorama.rgb = {32, 32, 90.0f, 1.25f};
  const int views = panorama.num_views;
  const auto size = static_cast<size_t>(viewLabelSize());
  ASSERT_EQ(size, houseObjectCategories().size() + houseColorNames().size() +
                      houseRoomTypes().size());
  const size_t roomsAt = size - houseRoomTypes().size();

  std::mt19937_64 rng(4);
  int seen = 0;
  for (int trial = 0; trial < 5; ++trial) {
    sim::AgentState agent;
    agent.position = scene->navmesh().randomPoint(rng);
    agent.heading = 0.3f;
    const std::vector<float> labels = viewLabelFeatures(
        *renderer, scene->semantics(), agent, panorama, /*minFraction=*/0.02f);
    ASSERT_EQ(labels.size(), static_cast<size_t>(views) * size);
    for (float x : labels) ASSERT_TRUE(x == 0.0f || x == 1.0f);
    // the room under the camera, one-hot, in every view alike
    const auto room = [&](int view) {
      const auto begin =
          labels.begin() + static_cast<std::ptrdiff_t>(
                               static_cast<size_t>(view) * size + roomsAt);
      return std::vector<float>(
          begin, begin + static_cast<std::ptrdiff_t>(houseRoomTypes().size()));
    };
    const std::vector<float> room0 = room(0);
    EXPECT_LE(std::accumulate(room0.begin(), room0.end(), 0.0f), 1.0f);
    for (int view = 1; view < views; ++view) EXPECT_EQ(room(view), room0);
    seen +=
        static_cast<int>(std::accumulate(labels.begin(), labels.end(), 0.0f));

    // turned left by one view, view k is what view k + 1 was
    sim::AgentState turned = agent;
    turned.heading = sim::panoramaViewHeading(agent.heading, 1, views);
    const std::vector<float> after = viewLabelFeatures(
        *renderer, scene->semantics(), turned, panorama, 0.02f);
    for (int view = 0; view < views; ++view) {
      const auto at = [&](const std::vector<float>& v, int k) {
        const auto begin =
            v.begin() +
            static_cast<std::ptrdiff_t>(static_cast<size_t>(k % views) * size);
        return std::vector<float>(begin,
                                  begin + static_cast<std::ptrdiff_t>(size));
      };
      EXPECT_EQ(at(after, view), at(labels, view + 1)) << "view " << view;
    }

    // nothing covers every pixel: no object at a fraction of 1
    const std::vector<float> none = viewLabelFeatures(
        *renderer, scene->semantics(), agent, panorama, /*minFraction=*/1.0f);
    for (int view = 0; view < views; ++view)
      for (size_t i = 0; i < roomsAt; ++i)
        EXPECT_EQ(none[static_cast<size_t>(view) * size + i], 0.0f);
  }
  EXPECT_GT(seen, 0) << "five panoramas in a furnished house saw nothing";
}

// ---------------------------------------------------------------------------
// the labels an instruction's goal names

TEST(GoalLabelsTest, AreWhatTheLastClauseNamingAPlaceNames) {
  const auto& categories = houseObjectCategories();
  const auto& colors = houseColorNames();
  const auto& rooms = houseRoomTypes();
  const auto C = static_cast<int64_t>(categories.size());
  const auto K = static_cast<int64_t>(colors.size());
  auto category = [&](const std::string& name) {
    return indexOf(categories, name);
  };
  auto color = [&](const std::string& name) {
    return C + indexOf(colors, name);
  };
  auto room = [&](const std::string& name) {
    return C + K + indexOf(rooms, name);
  };
  auto named = [](const std::vector<float>& labels) {
    std::vector<std::pair<int64_t, float>> out;
    for (size_t i = 0; i < labels.size(); ++i)
      if (labels[i] != 0.0f)
        out.emplace_back(static_cast<int64_t>(i), labels[i]);
    return out;
  };
  using Named = std::vector<std::pair<int64_t, float>>;

  // the bathroom is left behind: the goal is the grey tub (a bathtub)
  std::vector<float> labels = goalLabels(
      "Turn left and leave the bathroom, then stand next to the grey tub.");
  ASSERT_EQ(static_cast<int64_t>(labels.size()), viewLabelSize());
  EXPECT_EQ(named(labels), (Named{{category("bathtub"), kGoalCategory},
                                  {color("grey"), kGoalColor}}));
  // a room type by another of its words
  EXPECT_EQ(named(goalLabels("Turn left. Go left, then stop in the lounge.")),
            (Named{{room("living room"), kGoalRoom}}));
  // a last clause naming nothing falls back to the one before it
  EXPECT_EQ(
      named(goalLabels("Walk past the white sofa, then stop.")),
      (Named{{category("sofa"), kGoalCategory}, {color("white"), kGoalColor}}));
  // "table" names both tables; a two-word phrase is matched whole
  EXPECT_EQ(named(goalLabels("Wait by the table")),
            (Named{{category("coffee table"), kGoalCategory},
                   {category("table"), kGoalCategory}}));
  EXPECT_EQ(named(goalLabels("Stop at the washing machine")),
            (Named{{category("washing machine"), kGoalCategory}}));
  EXPECT_TRUE(named(goalLabels("Stop at the washing")).empty());
  // a colour alone names no place; nothing, or no text, names nothing
  EXPECT_TRUE(named(goalLabels("Go straight. Stop at the red one.")).empty());
  EXPECT_TRUE(named(goalLabels("")).empty());
  // a hostile length: 40,000 clauses that name nothing, the goal first
  std::string longText = "Stop by the sofa";
  for (int i = 0; i < 40000; ++i) longText += ", walk on";
  EXPECT_EQ(named(goalLabels(longText)),
            (Named{{category("sofa"), kGoalCategory}}));
}

}  // namespace
}  // namespace vln::world
