// SemanticNet: one logit per head output for every image, the RGB encoder's
// parameters under "rgb." (what the pretrainer saves for model.rgb_weights),
// and clear errors for images of the wrong rank and for a config that
// reads semantic heads itself.

#include "models/SemanticNet.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace vln::models {
namespace {

using ::testing::HasSubstr;

TEST(SemanticNetTest, OneLogitPerOutputOfEachHead) {
  ModelConfig model;
  model.rgb_encoder = EncoderType::kSmallCnn;
  model.rgb_width = model.rgb_height = 32;
  torch::manual_seed(1);
  SemanticNet net(model, /*categories=*/7, /*colors=*/5, /*rooms=*/3);
  const torch::Tensor images =
      torch::randint(0, 256, {4, 32, 32, 3}, torch::kUInt8);
  const SemanticLogits logits = net->forward(images);
  EXPECT_EQ(logits.categories.sizes(), (std::vector<int64_t>{4, 7}));
  EXPECT_EQ(logits.colors.sizes(), (std::vector<int64_t>{4, 5}));
  EXPECT_EQ(logits.room.sizes(), (std::vector<int64_t>{4, 3}));
  int encoderTensors = 0;
  for (const auto& item : net->named_parameters())
    if (item.key().rfind("rgb.", 0) == 0) ++encoderTensors;
  EXPECT_GT(encoderTensors, 0);
  // the pretraining cannot read heads of its own
  ModelConfig reading = model;
  reading.rgb_semantic_outputs = 15;
  EXPECT_THAT([&] { SemanticNet(reading, 7, 5, 3); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("model.rgb_semantic_outputs must be 0")));
  EXPECT_THAT([&] { net->forward(images[0]); },
              ::testing::Throws<c10::Error>(
                  ::testing::Property(&c10::Error::what_without_backtrace,
                                      HasSubstr("expected rgb [N, H, W, 3]"))));
}

}  // namespace
}  // namespace vln::models
