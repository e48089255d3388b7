// Tests of src/train/ExperimentConfig.cpp: checks across config sections.

#include "train/ExperimentConfig.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/TestPaths.h"
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

// the recollect trainer trains at trainer.lr throughout: a schedule it
// would ignore is refused
TEST(ExperimentConfigTest, CosineLearningRateNeedsTheDaggerMode) {
  ExperimentConfig c;
  c.trainer.lr_schedule = "cosine";
  EXPECT_EQ(errorOf([&] { c.validate(); }), "");
  c.trainer.mode = "recollect";
  EXPECT_THAT(errorOf([&] { c.validate(); }),
              HasSubstr("trainer.lr_schedule 'cosine' needs trainer.mode "
                        "dagger"));
  c.trainer.lr_schedule = "constant";
  EXPECT_EQ(errorOf([&] { c.validate(); }), "");
}

// rxr_text features are looked up by RxR's instruction ids: R2R episode
// files have none
TEST(ExperimentConfigTest, TextFeaturesNeedTheRxrFormatAndAValidFilter) {
  ExperimentConfig c;
  c.model.instruction_features = models::InstructionFeatures::kRxrText;
  EXPECT_THAT(errorOf([&] { c.validate(); }),
              HasSubstr("model.instruction_features is rxr_text"));
  c.dataset.format = "rxr";
  EXPECT_EQ(errorOf([&] { c.validate(); }), "");
  c.dataset.rxr_filter.roles = {"narrator"};
  EXPECT_THAT(errorOf([&] { c.validate(); }),
              HasSubstr("dataset.rxr_filter: RxrFilterConfig: roles: unknown "
                        "role 'narrator'"));
  // an R2R run ignores the filter
  c.dataset.format = "r2r";
  c.model.instruction_features = models::InstructionFeatures::kTokens;
  EXPECT_EQ(errorOf([&] { c.validate(); }), "");
}

// the shipped RxR run config: RxR-Habitat's task at CPU scale, CMA on
// text features with six actions, the guide role, R2R keys untouched
TEST(ExperimentConfigTest, RxrCmaConfigLoads) {
  const ExperimentConfig c = loadExperimentConfig(
      vln::test::sourcePath() / "configs" / "rxr" / "cma.yaml");
  EXPECT_EQ(c.dataset.format, "rxr");
  EXPECT_EQ(c.dataset.rxr_filter.roles, std::vector<std::string>{"guide"});
  EXPECT_EQ(c.dataset.textFeaturesPath(),
            std::filesystem::path("data/datasets/RxR_VLNCE_procedural") /
                "text_features");
  EXPECT_TRUE(c.model.usesTextFeatures());
  EXPECT_EQ(c.model.num_actions, 6);
  EXPECT_TRUE(c.sim.agent.look_actions);
  EXPECT_FLOAT_EQ(c.sim.agent.turn_angle, 30.0f);
  EXPECT_EQ(c.sim.rgb.width, 64);
  EXPECT_FLOAT_EQ(c.sim.rgb.hfov, 79.0f);
  EXPECT_FLOAT_EQ(c.sim.rgb.position_y, 0.88f);
  // the default dataset section stays R2R's
  EXPECT_EQ(ExperimentConfig{}.dataset.format, "r2r");
}

}  // namespace
}  // namespace vln::train
