// Tests of src/train/ExperimentConfig.cpp: checks across config sections.

#include "train/ExperimentConfig.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/TestUtil.h"

namespace vln::train {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using vln::test::errorOf;

TEST(ExperimentConfigTest, SixActionModelNeedsTheLookActions) {
  ExperimentConfig c;
  c.model.num_actions = 6;
  EXPECT_THAT(errorOf([&] { c.validate(); }),
              HasSubstr("model.num_actions is 6 (LOOK_UP, LOOK_DOWN) but "
                        "sim.agent.look_actions is false"));
  c.sim.agent.look_actions = true;
  EXPECT_THAT(errorOf([&] { c.validate(); }), Not(HasSubstr("num_actions")));
  // a four-action policy on RxR's simulator runs (it never looks)
  c.model.num_actions = 4;
  EXPECT_THAT(errorOf([&] { c.validate(); }), Not(HasSubstr("num_actions")));
}

}  // namespace
}  // namespace vln::train
