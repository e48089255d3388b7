// Tests src/viz/LearningCurve.cpp on synthetic metrics.jsonl files: the
// validations read back with their updates and training wall time (a
// resumed run, a file from before "start" records), the axes' ranges and
// ticks, the curves' points drawn where the layout says, the PNG, and
// errors on malformed files naming the file and the line.

#include "viz/LearningCurve.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>

#include "common/FileIo.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::viz {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

// A run validated after each of three epochs, killed after the second
// validation and resumed: the first process starts at t = 990 (its start
// record at 1000 after 10 s of setup) and ends at 1250; the second starts
// at 4980. val_seen is validated too.
constexpr const char* kResumedRun =
    R"({"type":"start","time":1000.0,"resumed":false,"checkpoint":-1,"updates":0,"setup_seconds":10.0}
{"type":"collect","time":1060.0,"seconds":50.0,"episodes":30}
{"type":"update","time":1070.0,"update":50,"loss":1.2}
{"type":"epoch","time":1120.0,"epoch":1,"updates":100,"seconds":60.0}
{"type":"eval","time":1150.0,"split":"val_unseen","checkpoint":0,"updates":100,"success":0.1,"spl":0.08,"num_episodes":100}
{"type":"eval","time":1160.0,"split":"val_seen","checkpoint":0,"updates":100,"success":0.5,"spl":0.45,"num_episodes":100}
{"type":"epoch","time":1220.0,"epoch":2,"updates":100,"seconds":60.0}
{"type":"eval","time":1250.0,"split":"val_unseen","checkpoint":1,"updates":200,"success":0.3,"spl":0.25,"num_episodes":100}

{"type":"start","time":5000.0,"resumed":true,"checkpoint":1,"updates":200,"setup_seconds":20.0}
{"type":"epoch","time":5100.0,"epoch":3,"updates":100,"seconds":60.0}
{"type":"eval","time":5130.0,"split":"val_unseen","checkpoint":2,"updates":300,"success":0.2,"spl":0.15,"num_episodes":100}
)";

class LearningCurveTest : public ::testing::Test {
 protected:
  fs::path write(const std::string& contents) {
    return vln::test::writeText(dir_ / "metrics.jsonl", contents);
  }
  vln::test::TempDir dir_;
};

TEST_F(LearningCurveTest, ReadsValidationsWithUpdatesAndTrainingTime) {
  const LearningCurve curve = readLearningCurve(write(kResumedRun));
  EXPECT_EQ(curve.split, "val_unseen");
  ASSERT_EQ(curve.points.size(), 3u);
  const CurvePoint& a = curve.points[0];
  EXPECT_EQ(a.checkpoint, 0);
  EXPECT_EQ(a.updates, 100);
  EXPECT_DOUBLE_EQ(a.seconds, 160.0);  // 1150 - (1000 - 10)
  EXPECT_DOUBLE_EQ(a.success, 0.1);
  EXPECT_DOUBLE_EQ(a.spl, 0.08);
  EXPECT_EQ(a.num_episodes, 100);
  EXPECT_DOUBLE_EQ(curve.points[1].seconds, 260.0);
  // the first process's 260 s, then 5130 - (5000 - 20); the 3.7 killed
  // hours between them do not count
  EXPECT_DOUBLE_EQ(curve.points[2].seconds, 260.0 + 150.0);
  EXPECT_EQ(curve.points[2].updates, 300);

  const LearningCurve seen =
      readLearningCurve(dir_ / "metrics.jsonl", "val_seen");
  ASSERT_EQ(seen.points.size(), 1u);
  EXPECT_DOUBLE_EQ(seen.points[0].success, 0.5);
}

TEST_F(LearningCurveTest, OlderFilesCountFromTheFirstRecordAndSumEpochUpdates) {
  // no start records, no updates in the eval records; checkpoint 0 was
  // evaluated twice (the last record wins)
  const LearningCurve curve = readLearningCurve(write(
      R"({"type":"collect","time":100.0,"seconds":40.0}
{"type":"epoch","time":130.0,"epoch":1,"updates":70}
{"type":"eval","time":150.0,"split":"val_unseen","checkpoint":0,"success":0.1,"spl":0.1}
{"type":"eval","time":155.0,"split":"val_unseen","checkpoint":0,"success":0.2,"spl":0.1}
{"type":"epoch","time":180.0,"epoch":2,"updates":80}
{"type":"eval","time":200.0,"split":"val_unseen","checkpoint":1,"success":0.3,"spl":0.2}
)"));
  ASSERT_EQ(curve.points.size(), 2u);
  EXPECT_DOUBLE_EQ(curve.points[0].seconds, 95.0);  // 155 - (100 - 40)
  EXPECT_DOUBLE_EQ(curve.points[0].success, 0.2);
  EXPECT_EQ(curve.points[0].updates, 70);
  EXPECT_DOUBLE_EQ(curve.points[1].seconds, 140.0);
  EXPECT_EQ(curve.points[1].updates, 150);
}

TEST_F(LearningCurveTest, AxesSpanTheDataWithNiceTicks) {
  const CurveLayout layout =
      layoutLearningCurve(readLearningCurve(write(kResumedRun)));
  // 410 s = 6.8 minutes -> 0..8 by 2
  EXPECT_FALSE(layout.hours);
  EXPECT_DOUBLE_EQ(layout.time.x.min, 0.0);
  EXPECT_DOUBLE_EQ(layout.time.x.max, 8.0);
  EXPECT_THAT(layout.time.x.ticks, ElementsAre(0.0, 2.0, 4.0, 6.0, 8.0));
  EXPECT_THAT(layout.time.x.label, HasSubstr("minutes"));
  // 300 updates -> 0..300 by 50
  EXPECT_DOUBLE_EQ(layout.updates.x.max, 300.0);
  EXPECT_EQ(layout.updates.x.ticks.size(), 7u);
  EXPECT_DOUBLE_EQ(layout.updates.x.ticks[1], 50.0);
  EXPECT_EQ(layout.updates.x.label, "optimizer updates");
  // the largest value 0.3, with 5% headroom -> 0..0.4 by 0.1
  for (const CurvePanel* panel : {&layout.time, &layout.updates}) {
    EXPECT_DOUBLE_EQ(panel->y.min, 0.0);
    EXPECT_NEAR(panel->y.max, 0.4, 1e-12);
    ASSERT_EQ(panel->y.ticks.size(), 5u);
    EXPECT_NEAR(panel->y.ticks[3], 0.3, 1e-12);
    EXPECT_EQ(panel->y.label, "val_unseen SR, SPL");
  }
  // the panels side by side, the corners of the axes where toPixel puts them
  EXPECT_LT(layout.time.right, layout.updates.left);
  const CurvePixel origin = layout.updates.toPixel(0.0, 0.0);
  EXPECT_EQ(origin.x, layout.updates.left);
  EXPECT_EQ(origin.y, layout.updates.bottom);
  const CurvePixel corner = layout.updates.toPixel(300.0, 0.4);
  EXPECT_EQ(corner.x, layout.updates.right);
  EXPECT_EQ(corner.y, layout.updates.top);

  // beyond 3 hours the time axis is in hours
  LearningCurve slow;
  slow.split = "val_unseen";
  slow.points = {CurvePoint{0, 10, 5.0 * 3600.0, 0.9, 0.8, 10}};
  const CurveLayout hours = layoutLearningCurve(slow);
  EXPECT_TRUE(hours.hours);
  EXPECT_THAT(hours.time.x.label, HasSubstr("hours"));
  EXPECT_DOUBLE_EQ(hours.time.x.max, 5.0);
  EXPECT_DOUBLE_EQ(hours.time.y.max, 1.0);  // never above 1
}

// the colour of pixel `p`
std::array<int, 3> at(const Image& image, CurvePixel p) {
  const size_t i = (static_cast<size_t>(p.y) * image.width + p.x) * 3;
  return {image.rgb[i], image.rgb[i + 1], image.rgb[i + 2]};
}
std::array<int, 3> rgbOf(const uint8_t (&c)[3]) { return {c[0], c[1], c[2]}; }

TEST_F(LearningCurveTest, PointsAreDrawnWhereTheLayoutPutsThem) {
  const LearningCurve curve = readLearningCurve(write(kResumedRun));
  CurveStyle style;
  style.title = "val_unseen learning curve: main/cma";
  const Image image = drawLearningCurve(curve, style);
  ASSERT_EQ(image.width, style.width);
  ASSERT_EQ(image.height, style.height);
  const CurveLayout layout = layoutLearningCurve(curve, style);
  for (const CurvePoint& p : curve.points) {
    // SR discs and SPL squares in both panels
    const double t = layout.timeValue(p);
    const auto u = static_cast<double>(p.updates);
    EXPECT_EQ(at(image, layout.time.toPixel(t, p.success)), rgbOf(kSuccessRgb))
        << "checkpoint " << p.checkpoint;
    EXPECT_EQ(at(image, layout.time.toPixel(t, p.spl)), rgbOf(kSplRgb))
        << "checkpoint " << p.checkpoint;
    EXPECT_EQ(at(image, layout.updates.toPixel(u, p.success)),
              rgbOf(kSuccessRgb));
    EXPECT_EQ(at(image, layout.updates.toPixel(u, p.spl)), rgbOf(kSplRgb));
  }
  // the line from checkpoint 0 to 1 passes half-way between their SR discs
  const CurvePixel a = layout.updates.toPixel(100.0, 0.1);
  const CurvePixel b = layout.updates.toPixel(200.0, 0.3);
  const auto middle = at(image, {(a.x + b.x) / 2, (a.y + b.y) / 2});
  for (int c = 0; c < 3; ++c)  // anti-aliased: within 40 levels
    EXPECT_NEAR(middle[c], kSuccessRgb[c], 40) << "channel " << c;
  // the best by SPL (checkpoint 1) is ringed in black, 9 pixels out
  const CurvePixel best = layout.updates.toPixel(200.0, 0.25);
  const auto ring = at(image, {best.x, best.y - 9});
  EXPECT_LT(ring[0] + ring[1] + ring[2], 3 * 80);
  // the plot area is white away from the curves and the grid, the axes black
  EXPECT_EQ(at(image, layout.updates.toPixel(280.0, 0.37)),
            (std::array<int, 3>{255, 255, 255}));
  EXPECT_EQ(
      at(image, {layout.time.left, (layout.time.top + layout.time.bottom) / 2}),
      (std::array<int, 3>{0, 0, 0}));
}

TEST_F(LearningCurveTest, SavesAPng) {
  const fs::path png = dir_ / "out" / "curve.png";
  const LearningCurve curve =
      saveLearningCurve(write(kResumedRun), png, "val_unseen");
  EXPECT_EQ(curve.points.size(), 3u);
  EXPECT_EQ(common::readFile(png).substr(0, 8), "\x89PNG\r\n\x1a\n");
}

TEST_F(LearningCurveTest, MalformedFilesNameTheFileAndLine) {
  auto errorOf = [&](const std::string& contents) {
    const fs::path file = write(contents);
    return vln::test::errorOf([&] { readLearningCurve(file); });
  };
  const std::string file = "'" + (dir_ / "metrics.jsonl").string() + "'";
  const std::string eval =
      R"({"type":"eval","time":1.0,"split":"val_unseen","checkpoint":0,"success":0.1,"spl":0.1})";
  EXPECT_THAT(errorOf(eval + "\n\n{not json\n"),
              HasSubstr(file + ":3: not a JSON object: '{not json'"));
  EXPECT_THAT(errorOf("[1, 2]\n"), HasSubstr(file + ":1: not a JSON object"));
  EXPECT_THAT(errorOf(R"({"time":1.0})"
                      "\n"),
              HasSubstr(file + ":1: field 'type' is missing"));
  EXPECT_THAT(
      errorOf(
          eval + "\n" +
          R"({"type":"eval","time":2.0,"split":"val_unseen","checkpoint":1,"success":0.2})"
          "\n"),
      HasSubstr(file + ":2: field 'spl' is missing"));
  EXPECT_THAT(
      errorOf(
          R"({"type":"eval","time":2.0,"split":"val_unseen","checkpoint":1,"success":"high","spl":0.1})"
          "\n"),
      HasSubstr(file + ":1: field 'success' must be a finite number, got "
                       "\"high\""));
  EXPECT_THAT(
      errorOf(
          R"({"type":"eval","time":2.0,"split":"val_unseen","checkpoint":1.5,"success":0.1,"spl":0.1})"
          "\n"),
      HasSubstr(file + ":1: field 'checkpoint' must be an integer"));
  EXPECT_THAT(errorOf(R"({"type":"epoch","time":2.0,"epoch":1})"
                      "\n"),
              HasSubstr(file + ":1: field 'updates' is missing"));
  // no validation of the split
  EXPECT_THAT(
      errorOf(R"({"type":"update","time":1.0,"update":2})"
              "\n"),
      HasSubstr(file + " has no \"eval\" record of split 'val_unseen'"));
  // a missing file
  EXPECT_THAT(
      vln::test::errorOf([&] { readLearningCurve(dir_ / "missing.jsonl"); }),
      HasSubstr("missing.jsonl"));
  // a writer killed mid-line leaves an unterminated last line: skipped
  EXPECT_EQ(readLearningCurve(write(eval + "\n" + R"({"type":"eval","ti)"))
                .points.size(),
            1u);
}

TEST_F(LearningCurveTest, BadLayoutRequestsAreErrors) {
  LearningCurve empty;
  empty.split = "val_unseen";
  EXPECT_THAT(vln::test::errorOf([&] { layoutLearningCurve(empty); }),
              HasSubstr("split 'val_unseen' has no point"));
  const LearningCurve curve = readLearningCurve(write(kResumedRun));
  CurveStyle tiny;
  tiny.width = 100;
  EXPECT_THAT(vln::test::errorOf([&] { drawLearningCurve(curve, tiny); }),
              HasSubstr("at least 400 x 240 pixels, got 100 x 520"));
}

}  // namespace
}  // namespace vln::viz
