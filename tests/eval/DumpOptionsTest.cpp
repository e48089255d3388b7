// The --dump-ids parser of src/eval/DumpOptions.cpp; the flags' checks
// through the eval command are in EvalCommandsTest.

#include "eval/DumpOptions.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/TestUtil.h"

namespace vln::eval {
namespace {

using ::testing::HasSubstr;

TEST(DumpOptionsTest, ParsesCommaSeparatedIds) {
  EXPECT_EQ(parseEpisodeIds("12", "--ids"), std::vector<int>{12});
  EXPECT_EQ(parseEpisodeIds("12,40, 7 ,0", "--ids"),
            (std::vector<int>{12, 40, 7, 0}));
}

TEST(DumpOptionsTest, BadListsNameTheFlag) {
  const auto errorOf = [](const char* text) {
    return vln::test::errorOf([&] { parseEpisodeIds(text, "--dump-ids"); });
  };
  EXPECT_THAT(errorOf(""), HasSubstr("--dump-ids: expected comma-separated "
                                     "episode ids, got '' (an empty entry)"));
  EXPECT_THAT(errorOf("1,,2"), HasSubstr("(an empty entry)"));
  EXPECT_THAT(errorOf("1,"), HasSubstr("(an empty entry)"));
  EXPECT_THAT(errorOf("1,a2"), HasSubstr("--dump-ids: 'a2' is not an episode "
                                         "id (an integer >= 0), in '1,a2'"));
  EXPECT_THAT(errorOf("3x"), HasSubstr("'3x' is not an episode id"));
  EXPECT_THAT(errorOf("-4"), HasSubstr("'-4' is not an episode id"));
  EXPECT_THAT(errorOf("99999999999"), HasSubstr("is not an episode id"));
  EXPECT_THAT(errorOf("5,6,5"),
              HasSubstr("--dump-ids: episode id 5 is listed twice"));
}

}  // namespace
}  // namespace vln::eval
