// Tests src/viz/EpisodeMap.cpp: the episode's drawings on the map, the map's
// size, labels that never overlap on a real house, the legend and the scale
// bar under it.

#include "viz/EpisodeMap.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "rollout/Evaluator.h"
#include "rollout/RolloutTestWorld.h"

namespace vln::viz {
namespace {

using rollout::test::rolloutTestWorld;

// pixels within 25 levels of `color` per channel (drawing is anti-aliased)
int countColor(const std::vector<uint8_t>& rgb, const sim::Rgb8& color) {
  int n = 0;
  auto near = [](int a, int b) { return std::abs(a - b) <= 25; };
  for (size_t i = 0; i + 2 < rgb.size(); i += 3)
    if (near(rgb[i], color[0]) && near(rgb[i + 1], color[1]) &&
        near(rgb[i + 2], color[2]))
      ++n;
  return n;
}
int countColor(const sim::TopDownMap& map, const sim::Rgb8& color) {
  return countColor(map.rgb(), color);
}

// the record of episode 0 replayed from its ground truth
const rollout::EpisodeRecord& replayedRecord() {
  static const rollout::EpisodeRecord record = [] {
    const auto& w = rolloutTestWorld();
    rollout::EpisodeRecord r;
    r.episode_id = std::to_string(w.episodes[0].episode_id);
    r.positions = w.followerPositions[0];
    r.headings.assign(r.positions.size(), 0.0f);
    r.reference_path = w.episodes[0].reference_path;
    r.goal = w.episodes[0].goals.front().position;
    return r;
  }();
  return record;
}

TEST(EpisodeMapTest, ShowsPathsStartGoalAndCircle) {
  const auto& w = rolloutTestWorld();
  const rollout::EpisodeRecord& record = replayedRecord();
  const MapStyle style{.meters_per_pixel = 0.05f};
  const sim::TopDownMap map =
      drawEpisodeMap(*w.scene, record, /*hasGoal=*/true, 3.0f, style);
  const sim::TopDownMap bare(*w.scene, 0.05f, record.positions[0].y());
  EXPECT_GT(countColor(map, kAgentColor), countColor(bare, kAgentColor) + 40);
  EXPECT_GT(countColor(map, kStartColor),
            countColor(bare, kStartColor) + 20);  // a 5 px disc
  // the goal disc and the 3 m circle (60 px radius at 0.05 m/px, 2 px
  // wide): several hundred pixels unless clipped by the border
  EXPECT_GT(countColor(map, kGoalColor), countColor(bare, kGoalColor) + 300);
  const sim::TopDownMap noGoal =
      drawEpisodeMap(*w.scene, record, /*hasGoal=*/false, 3.0f, style);
  EXPECT_LT(countColor(noGoal, kGoalColor), countColor(bare, kGoalColor) + 10);
  // the reference runs under the agent's path; alone, it shows
  rollout::EpisodeRecord standing = record;
  standing.positions.resize(1);
  standing.headings.resize(1);
  const sim::TopDownMap reference =
      drawEpisodeMap(*w.scene, standing, true, 3.0f, style);
  EXPECT_GT(countColor(reference, kReferenceColor),
            countColor(bare, kReferenceColor) + 60);
}

TEST(EpisodeMapTest, ShowsAWaypointAgentsCandidatesAndChoices) {
  const auto& w = rolloutTestWorld();
  rollout::EpisodeRecord record = replayedRecord();
  const MapStyle style{.meters_per_pixel = 0.05f};
  const sim::TopDownMap plain =
      drawEpisodeMap(*w.scene, record, true, 3.0f, style);
  EXPECT_FALSE(mapLegendOf(record, true, 3.0f).waypoints);
  // two decisions along the path: three candidates each, the first one
  // chosen, then STOP
  for (size_t i : {size_t{0}, record.positions.size() / 2}) {
    rollout::WaypointChoice choice;
    choice.position = record.positions[i];
    for (float dx : {-1.0f, 0.0f, 1.0f})
      choice.candidates.push_back(record.positions[i] + Vec3f(dx, 0.0f, 1.0f));
    choice.chosen = i == 0 ? 0 : -1;
    record.waypoint_choices.push_back(choice);
  }
  const sim::TopDownMap map =
      drawEpisodeMap(*w.scene, record, true, 3.0f, style);
  EXPECT_GT(countColor(map, kCandidateColor),
            countColor(plain, kCandidateColor) + 6 * 5);
  // one chosen line of about 1.4 m: ~28 px at 0.05 m/px
  EXPECT_GT(countColor(map, kChosenColor),
            countColor(plain, kChosenColor) + 15);
  const MapLegend legend = mapLegendOf(record, true, 3.0f);
  EXPECT_TRUE(legend.waypoints);
  const Image picture = mapPicture(map, legend);
  const std::vector<uint8_t> footer(
      picture.rgb.begin() + static_cast<long>(map.rgb().size()),
      picture.rgb.end());
  EXPECT_GT(countColor(footer, kCandidateColor), 10);
  EXPECT_GT(countColor(footer, kChosenColor), 10);
}

TEST(EpisodeMapTest, LegibleSizeWithStrokesThatKeepTheirWidth) {
  const auto& w = rolloutTestWorld();
  const rollout::EpisodeRecord& record = replayedRecord();
  const sim::TopDownMap map = drawEpisodeMap(*w.scene, record, true, 3.0f);
  EXPECT_EQ(std::max(map.width(), map.height()), 1024);
  const sim::TopDownMap coarse = drawEpisodeMap(
      *w.scene, record, true, 3.0f, MapStyle{.meters_per_pixel = 0.05f});
  // the agent's path covers about as much floor in metres at either scale:
  // pixels scale with the square of the resolution
  const double ratio =
      std::pow(coarse.metersPerPixel() / map.metersPerPixel(), 2.0);
  const sim::TopDownMap bare(*w.scene, map.metersPerPixel(),
                             record.positions[0].y());
  const sim::TopDownMap bareCoarse(*w.scene, 0.05f, record.positions[0].y());
  const double fine =
      countColor(map, kAgentColor) - countColor(bare, kAgentColor);
  const double coarsePixels =
      countColor(coarse, kAgentColor) - countColor(bareCoarse, kAgentColor);
  EXPECT_GT(fine, 0.4 * ratio * coarsePixels);
}

TEST(EpisodeMapTest, LabelsOfAHouseNeverOverlap) {
  const auto& w = rolloutTestWorld();
  for (int longSide : {1024, 400, 160}) {
    SCOPED_TRACE(longSide);
    const float y = replayedRecord().positions[0].y();
    const sim::TopDownMap map(
        *w.scene,
        sim::TopDownMap::metersPerPixelForLongSide(*w.scene, y, longSide), y);
    const auto& labels = map.placedLabels();
    if (longSide == 1024) {
      EXPECT_GE(labels.size(), 5u);  // a furnished house of 3-4 rooms
      EXPECT_LE(map.droppedLabels().size(), labels.size() / 4);
    }
    for (size_t i = 0; i < labels.size(); ++i) {
      const sim::MapLabel& a = labels[i];
      EXPECT_GE(a.x, 0);
      EXPECT_GE(a.y, 0);
      EXPECT_LE(a.x + a.width, map.width());
      EXPECT_LE(a.y + a.height, map.height());
      for (size_t j = i + 1; j < labels.size(); ++j) {
        const sim::MapLabel& b = labels[j];
        const bool apart = a.x + a.width <= b.x || b.x + b.width <= a.x ||
                           a.y + a.height <= b.y || b.y + b.height <= a.y;
        EXPECT_TRUE(apart) << a.text << " and " << b.text << " overlap";
      }
    }
  }
}

TEST(EpisodeMapTest, ScaleBarIsARoundLengthThatFits) {
  EXPECT_FLOAT_EQ(chooseScaleBar(0.01f, 240).meters, 2.0f);  // 2.4 m fit
  EXPECT_EQ(chooseScaleBar(0.01f, 240).pixels, 200);
  EXPECT_FLOAT_EQ(chooseScaleBar(0.05f, 100).meters, 5.0f);  // exactly 5 m
  EXPECT_FLOAT_EQ(chooseScaleBar(0.05f, 99).meters, 2.0f);
  EXPECT_FLOAT_EQ(chooseScaleBar(0.002f, 240).meters, 0.2f);
  EXPECT_FLOAT_EQ(chooseScaleBar(1.0f, 240).meters, 200.0f);
  EXPECT_THROW(chooseScaleBar(0.0f, 100), std::invalid_argument);
  EXPECT_THROW(chooseScaleBar(0.05f, 0), std::invalid_argument);
}

TEST(EpisodeMapTest, PictureHasTheMapOverALegendAndScaleBar) {
  const auto& w = rolloutTestWorld();
  const sim::TopDownMap map =
      drawEpisodeMap(*w.scene, replayedRecord(), true, 3.0f);
  const MapLegend legend;
  const Image picture = mapPicture(map, legend);
  ASSERT_EQ(picture.width, map.width());
  const int footer = footerHeight(map.width(), map.metersPerPixel(), legend);
  ASSERT_EQ(picture.height, map.height() + footer);
  EXPECT_GE(footer, 30);
  // the map unchanged on top
  EXPECT_TRUE(
      std::equal(map.rgb().begin(), map.rgb().end(), picture.rgb.begin()));
  // the footer shows every legend colour and black text and bar
  const std::vector<uint8_t> footerPixels(
      picture.rgb.begin() + static_cast<long>(map.rgb().size()),
      picture.rgb.end());
  for (const sim::Rgb8& c :
       {kReferenceColor, kAgentColor, kStartColor, kGoalColor})
    EXPECT_GT(countColor(footerPixels, c), 10)
        << int(c[0]) << "," << int(c[1]) << "," << int(c[2]);
  EXPECT_GT(countColor(footerPixels, sim::Rgb8{0, 0, 0}), 200);
  // without a goal the legend has no goal entries
  const Image noGoal = mapPicture(map, MapLegend{.goal = false});
  const std::vector<uint8_t> noGoalFooter(
      noGoal.rgb.begin() + static_cast<long>(map.rgb().size()),
      noGoal.rgb.end());
  EXPECT_LT(countColor(noGoalFooter, kGoalColor), 5);
  // a narrow map wraps the legend onto more rows
  EXPECT_GT(footerHeight(200, map.metersPerPixel(), legend), footer);
  // and the picture encodes
  const std::string png = encodePng(picture);
  EXPECT_EQ(png.substr(1, 3), "PNG");
}

}  // namespace
}  // namespace vln::viz
