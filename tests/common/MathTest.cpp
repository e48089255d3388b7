#include "common/Math.h"

#include <gtest/gtest.h>

namespace vln {
namespace {

TEST(MathTest, HabitatHeadingConvention) {
  Vec3f f0 = headingToForward(0.0f);
  EXPECT_NEAR(f0.z(), -1.0f, 1e-6);
  // a left turn of 90 degrees looks along -X
  Vec3f left = headingToForward(degToRad(90.0f));
  EXPECT_NEAR(left.x(), -1.0f, 1e-6);
  EXPECT_NEAR(left.z(), 0.0f, 1e-6);
}

TEST(MathTest, QuaternionRoundTrip) {
  for (float deg = -179.0f; deg < 180.0f; deg += 13.0f) {
    float h = degToRad(deg);
    EXPECT_NEAR(wrapAngle(quaternionToHeading(headingToQuaternion(h)) - h), 0.0f, 1e-5);
    EXPECT_NEAR(wrapAngle(forwardToHeading(headingToForward(h)) - h), 0.0f, 1e-5);
  }
  // a real R2R_VLNCE start_rotation (val_seen episode 1): yaw 210 degrees
  float h = quaternionToHeading({-0.0f, 0.9659258f, -0.0f, -0.2588190f});
  EXPECT_NEAR(wrapAngle(h - degToRad(210.0f)), 0.0f, 1e-5);
}

}  // namespace
}  // namespace vln
