// Tests src/data/RxrTextFeatures.cpp: VLN-CE's feature path template, the
// [512, 768] block (zero rows after the file's rows, the first 512 kept),
// errors naming the file, and a feature file written by numpy.

#include "data/RxrTextFeatures.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "common/FileIo.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::data {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using vln::test::errorOf;

std::vector<float> rows(int n, int dim) {
  std::vector<float> v(static_cast<size_t>(n) * static_cast<size_t>(dim));
  for (size_t i = 0; i < v.size(); ++i)
    v[i] = static_cast<float>(i % 1000) * 0.001f + 1.0f;
  return v;
}

TEST(RxrTextFeaturesTest, PathFollowsVlnceTemplate) {
  // features_path =
  // .../text_features/rxr_{split}/{id:06}_{lang}_text_features.npz with lang =
  // language.split("-")[0]
  EXPECT_EQ(rxrTextFeaturesPath("tf", "val_seen", 42, "en-IN"),
            fs::path("tf/rxr_val_seen/000042_en_text_features.npz"));
  EXPECT_EQ(rxrTextFeaturesPath("tf", "train", 1234567, "hi-IN"),
            fs::path("tf/rxr_train/1234567_hi_text_features.npz"));
  EXPECT_EQ(rxrLanguagePrefix("te-IN"), "te");
  EXPECT_EQ(rxrLanguagePrefix("en"), "en");
  EXPECT_THAT(errorOf([] { rxrTextFeaturesPath("tf", "train", -1, "en-US"); }),
              HasSubstr("negative"));
}

TEST(RxrTextFeaturesTest, PadsWithZeroRowsAfterTheTokens) {
  vln::test::TempDir dir;
  const fs::path file = rxrTextFeaturesPath(dir.path(), "train", 7, "en-US");
  const std::vector<float> three = rows(3, kRxrTextFeatureDim);
  writeRxrTextFeatures(file, three, kRxrTextFeatureDim);
  const RxrTextFeatures f =
      loadRxrTextFeatures(dir.path(), "train", 7, "en-US");
  EXPECT_EQ(f.tokens, 512);
  EXPECT_EQ(f.dim, 768);
  EXPECT_EQ(f.valid_tokens, 3);
  ASSERT_EQ(f.values.size(), 512u * 768u);
  EXPECT_TRUE(std::equal(three.begin(), three.end(), f.values.begin()));
  EXPECT_TRUE(std::all_of(f.values.begin() + 3 * 768, f.values.end(),
                          [](float v) { return v == 0.0f; }));
}

TEST(RxrTextFeaturesTest, KeepsTheFirstRowsOfALongerFile) {
  vln::test::TempDir dir;
  const std::vector<float> many = rows(600, 8);
  writeRxrTextFeatures(dir / "long.npz", many, 8);
  const RxrTextFeatures f =
      loadRxrTextFeatures(dir / "long.npz", /*tokens=*/512, /*dim=*/8);
  EXPECT_EQ(f.valid_tokens, 512);
  EXPECT_TRUE(std::equal(f.values.begin(), f.values.end(), many.begin()));
}

TEST(RxrTextFeaturesTest, RefusesBadFeatureFilesNamingThem) {
  vln::test::TempDir dir;
  writeRxrTextFeatures(dir / "narrow.npz", rows(4, 512), 512);
  EXPECT_THAT(errorOf([&] { loadRxrTextFeatures(dir / "narrow.npz"); }),
              AllOf(HasSubstr("narrow.npz"), HasSubstr("[tokens, 768]"),
                    HasSubstr("[4, 512]")));
  writeNpz(dir / "other.npz", {{"tokens", {{2}, {1.0f, 2.0f}}}});
  EXPECT_THAT(errorOf([&] { loadRxrTextFeatures(dir / "other.npz"); }),
              AllOf(HasSubstr("other.npz"), HasSubstr("no array 'features'")));
  // other arrays are not parsed: an int array beside the features is fine
  const std::string ints =
      "{'descr': '<i4', 'fortran_order': False, "
      "'shape': (1,), }";
  std::string npy("\x93NUMPY\x01\x00", 8);
  npy += static_cast<char>(ints.size() + 1);
  npy += '\0';
  npy += ints + "\n" + std::string(4, '\0');
  common::writeFileAtomic(
      dir / "mixed.npz",
      storedZipBytes({{"tokens.npy", npy},
                      {"features.npy", npyBytes({{1, 768}, rows(1, 768)})}}));
  EXPECT_EQ(loadRxrTextFeatures(dir / "mixed.npz").valid_tokens, 1);
  EXPECT_THAT(errorOf([&] { readNpz(dir / "mixed.npz"); }),
              HasSubstr("array 'tokens': unsupported dtype '<i4'"));
  std::vector<float> nan = rows(2, 768);
  nan[768 + 5] = std::nanf("");
  writeRxrTextFeatures(dir / "nan.npz", nan, 768);
  EXPECT_THAT(errorOf([&] { loadRxrTextFeatures(dir / "nan.npz"); }),
              AllOf(HasSubstr("nan.npz"), HasSubstr("row 1, column 5")));
  EXPECT_THAT(
      errorOf([&] { loadRxrTextFeatures(dir.path(), "test", 3, "te-IN"); }),
      HasSubstr("rxr_test/000003_te_text_features.npz"));
}

TEST(RxrTextFeaturesTest, LoadsAFileWrittenByNumpy) {
  if (!fs::exists("/usr/bin/python3") ||
      vln::test::runCommand("/usr/bin/python3 -c 'import numpy'") != 0)
    GTEST_SKIP() << "no /usr/bin/python3 with numpy";
  vln::test::TempDir dir;
  fs::create_directories(dir / "rxr_val_unseen");
  std::string output;
  ASSERT_EQ(vln::test::runCommand(
                "cd " + dir.path().string() +
                    " && /usr/bin/python3 -c 'import numpy as np; "
                    "np.savez_compressed(\"rxr_val_unseen/000123_hi_text_"
                    "features.npz\", features=np.arange(5 * 768, "
                    "dtype=np.float32).reshape(5, 768) / 768)' 2>&1",
                &output),
            0)
      << output;
  const RxrTextFeatures f =
      loadRxrTextFeatures(dir.path(), "val_unseen", 123, "hi-IN");
  EXPECT_EQ(f.valid_tokens, 5);
  EXPECT_FLOAT_EQ(f.values[768 * 4 + 767], (5.0f * 768 - 1) / 768);
  EXPECT_EQ(f.values[768 * 5], 0.0f);
}

}  // namespace
}  // namespace vln::data
