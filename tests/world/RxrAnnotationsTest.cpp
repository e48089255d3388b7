#include "world/RxrAnnotations.h"

#include <gtest/gtest.h>

#include <vector>

namespace vln::world {
namespace {

TEST(RxrAnnotationsTest, WalkTimesAddLegsAtTheSpeedAndPausesAtNodes) {
  // legs of 2 m and 4 m at 0.5 m/s, 1 s pauses at the start and the middle
  const std::vector<Vec3f> waypoints = {{0, 0, 0}, {2, 0, 0}, {2, 0, -4}};
  const WalkTimes t = walkTimes(waypoints, /*speed=*/0.5, /*pause=*/1.0);
  ASSERT_EQ(t.arrival.size(), 3u);
  EXPECT_DOUBLE_EQ(t.arrival[1], 1.0 + 4.0);
  EXPECT_DOUBLE_EQ(t.departure[1], 6.0);
  EXPECT_DOUBLE_EQ(t.arrival[2], 6.0 + 8.0);
  EXPECT_DOUBLE_EQ(t.departure[2], 14.0);  // no pause at the goal
  EXPECT_DOUBLE_EQ(t.duration(), 14.0);
  EXPECT_THROW(walkTimes(waypoints, 0.0, 1.0), std::invalid_argument);
}

TEST(RxrAnnotationsTest, PhrasesAreSpokenWhenTheWalkReachesThem) {
  const std::vector<Vec3f> waypoints = {
      {0, 0, 0}, {2, 0, 0}, {2, 0, -4}, {6, 0, -4}};
  const WalkTimes times = walkTimes(waypoints, 1.0, 0.0);  // 0, 2, 6, 10 s
  GeneratedInstruction g;
  g.text = "Walk ahead, turn left at the red chair. Stop by the sofa.";
  g.landmarks.push_back(
      {.role = LandmarkRole::kTurnAt, .phrase = "red chair", .leg = 1});
  g.landmarks.push_back(
      {.role = LandmarkRole::kStop, .phrase = "sofa", .leg = 3});
  const std::vector<data::TimedWord> words = timeInstruction(g, times);
  ASSERT_EQ(words.size(), 12u);
  EXPECT_EQ(words[1].word, "ahead");  // punctuation dropped
  EXPECT_EQ(words[6].word, "red");
  EXPECT_DOUBLE_EQ(*words[6].start_time, 2.0);  // arriving at waypoint 1
  EXPECT_EQ(words[11].word, "sofa");
  EXPECT_DOUBLE_EQ(*words[11].start_time, 6.0);  // starting the last leg
  EXPECT_DOUBLE_EQ(*words[0].start_time, 0.0);
  double previous = 0.0;
  for (const data::TimedWord& w : words) {
    EXPECT_GE(*w.start_time, previous);
    EXPECT_LE(*w.start_time, *w.end_time);
    previous = *w.end_time;
  }
  EXPECT_LE(previous, 10.0);
}

TEST(RxrAnnotationsTest, AnchorsOutOfOrderNeverMakeTimeGoBack) {
  const std::vector<Vec3f> waypoints = {{0, 0, 0}, {4, 0, 0}, {8, 0, 0}};
  GeneratedInstruction g;
  g.text = "Stop near the lamp after you pass the table.";
  g.landmarks.push_back(
      {.role = LandmarkRole::kStop, .phrase = "lamp", .leg = 2});
  g.landmarks.push_back(
      {.role = LandmarkRole::kPass, .phrase = "table", .leg = 0});
  const auto words = timeInstruction(g, walkTimes(waypoints, 1.0, 0.0));
  double previous = 0.0;
  for (const data::TimedWord& w : words) {
    EXPECT_GE(*w.start_time, previous);
    previous = *w.end_time;
  }
}

TEST(RxrAnnotationsTest, IndianEnglishChangesWordsOneForOne) {
  EXPECT_EQ(toIndianEnglish("Go into the bathroom, then walk to the living "
                            "room couch."),
            "Proceed into the washroom, then move to the drawing room sofa.");
  EXPECT_EQ(toIndianEnglish("the living area"), "the living area");
  EXPECT_EQ(toIndianEnglish(""), "");
}

}  // namespace
}  // namespace vln::world
