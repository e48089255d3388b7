// Tests src/data/Glove.cpp: GloVe text files and the embeddings.json matrix
// (checked against the real R2R_VLNCE embeddings); plus the `embeddings`
// command of src/data/DataCommands.cpp.

#include "data/Glove.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "common/FileIo.h"
#include "common/Json.h"
#include "data/DataCommands.h"
#include "data/Episode.h"
#include "data/WordVectorRows.h"
#include "support/TestPaths.h"

namespace vln::data {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

using test::row;

// =========================================================================
// text files
// =========================================================================

TEST(GloveTest, ReadsRowsIncludingSpacedTokensAndKeepsFirstDuplicate) {
  WordVectors vectors = readGloveText(test::r2rFixture("tiny_glove.txt"));
  EXPECT_EQ(vectors.dim(), 3);
  EXPECT_THAT(vectors.words(),
              ElementsAre("the", "walk", ". . .", "at name@domain.com",
                          "stairs", "turn"));
  EXPECT_THAT(row(vectors, "the"), ElementsAre(0.1f, 0.2f, 0.3f));
  EXPECT_THAT(row(vectors, "walk"), ElementsAre(-0.5f, 0.25f, 1e-3f));
  EXPECT_THAT(row(vectors, ". . ."), ElementsAre(0.5f, 0.5f, 0.5f));
  EXPECT_THAT(row(vectors, "at name@domain.com"),
              ElementsAre(1.0f, 2.0f, 3.0f));
  EXPECT_FALSE(vectors.find("at").has_value());
}

TEST(GloveTest, ToleratesHeadersCrlfGzipAndFiltersWords) {
  test::TempDir dir;
  test::writeText(dir / "w2v.txt", "2 2\r\nleft 1 2\r\nright 3 4 \r\n\r\n");
  WordVectors vectors = readGloveText(dir / "w2v.txt");
  EXPECT_EQ(vectors.dim(), 2);
  EXPECT_THAT(vectors.words(), ElementsAre("left", "right"));
  EXPECT_THAT(row(vectors, "right"), ElementsAre(3.0f, 4.0f));
  GloveReadOptions twoD;
  twoD.dim = 2;
  EXPECT_EQ(readGloveText(dir / "w2v.txt", twoD).size(), 2);
  twoD.dim = 1;
  test::writeText(dir / "one.txt", "7 3\nx 0.5\n");
  EXPECT_THAT(readGloveText(dir / "one.txt", twoD).words(),
              ElementsAre("7", "x"));
  // glove.840B has rows whose word is empty; nothing could look them up
  test::writeText(dir / "empty.txt", "a 1 2\n 3 4\nb 5 6\n");
  EXPECT_THAT(readGloveText(dir / "empty.txt").words(), ElementsAre("a", "b"));

  // gzip is detected by content; only_words keeps the requested rows
  common::writeFileAtomic(dir / "glove.txt.gz",
                          common::readFile(test::r2rFixture("tiny_glove.txt")));
  GloveReadOptions options;
  options.only_words = {"walk", "turn", "absent"};
  WordVectors filtered = readGloveText(dir / "glove.txt.gz", options);
  EXPECT_THAT(filtered.words(), ElementsAre("walk", "turn"));
  EXPECT_THAT(row(filtered, "turn"), ElementsAre(0.75f, -0.125f, 0.0625f));
}

TEST(GloveTest, RaggedAndNonNumericRowsNameFileAndLine) {
  test::TempDir dir;
  struct Case {
    std::string text;
    int dim;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {"a 1 2 3\nb 1 2 3\nc 1 2\n", 0, "line 3: ragged row"},
      {"a 1 2 3\nb 1 2 3 4\n", 0, "line 2: ragged row, more than 3 values"},
      {"a 1 2 3\nb 1 x 3\n", 0, "line 2: value 2 is not a finite number"},
      {"a 1 2 3\nb 1 nan 3\n", 0, "line 2: value 2 is not a finite number"},
      {"a 1 2 3\n", 4, "line 1: ragged row"},
      {"lonely\n", 0, "line 1: expected 'word v1 ... vN'"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.text);
    test::writeText(dir / "bad_glove.txt", c.text);
    GloveReadOptions options;
    options.dim = c.dim;
    EXPECT_THAT([&] { readGloveText(dir / "bad_glove.txt", options); },
                ThrowsMessage<std::invalid_argument>(
                    AllOf(HasSubstr("bad_glove.txt"), HasSubstr(c.expected))));
  }
  std::string packed = common::gzipCompress(std::string(20000, '1'));
  test::writeText(dir / "cut.txt.gz", packed.substr(0, packed.size() / 2));
  EXPECT_THAT([&] { readGloveText(dir / "cut.txt.gz"); },
              ThrowsMessage<std::runtime_error>(
                  AllOf(HasSubstr("cut.txt.gz"), HasSubstr("truncated"))));
  EXPECT_THAT([&] { readGloveText(dir / "absent.txt"); },
              ThrowsMessage<std::runtime_error>(HasSubstr("absent.txt")));
}

TEST(GloveTest, TextRoundTripIsExact) {
  test::TempDir dir;
  WordVectors vectors(3);
  vectors.add("left", std::vector<float>{0.1f, -1e-7f, 3.14159274f});
  vectors.add("t-intersection", std::vector<float>{1e20f, -0.0f, 2.5f});
  EXPECT_FALSE(vectors.add("left", std::vector<float>{9, 9, 9}));
  writeGloveText(dir / "out.txt", vectors);
  WordVectors back = readGloveText(dir / "out.txt");
  ASSERT_EQ(back.words(), vectors.words());
  for (int i = 0; i < vectors.size(); ++i)
    EXPECT_TRUE(std::equal(back.vector(i).begin(), back.vector(i).end(),
                           vectors.vector(i).begin()));
  EXPECT_THAT(
      [&] {
        vectors.add("x", std::vector<float>{1, 2});
      },
      ThrowsMessage<std::invalid_argument>(
          HasSubstr("word 'x' has 2 values, expected 3")));
}

// =========================================================================
// embedding matrices
// =========================================================================

TEST(GloveTest, EmbeddingMatrixHasZeroPadMeanUnkAndMissingPolicy) {
  Vocabulary vocab({"<pad>", "<unk>", "left", "nowhere", "right"});
  WordVectors vectors(2);
  vectors.add("left", std::vector<float>{1.0f, 2.0f});
  vectors.add("right", std::vector<float>{3.0f, -4.0f});
  vectors.add("unused", std::vector<float>{100.0f, 100.0f});

  EmbeddingBuildReport report;
  EmbeddingMatrix matrix = buildEmbeddingMatrix(vocab, vectors, {}, &report);
  EXPECT_EQ(matrix.rows, 5);
  EXPECT_EQ(matrix.dim, 2);
  EXPECT_THAT(matrix.row(0), ElementsAre(0.0f, 0.0f));   // <pad>
  EXPECT_THAT(matrix.row(1), ElementsAre(2.0f, -1.0f));  // mean of found
  EXPECT_THAT(matrix.row(2), ElementsAre(1.0f, 2.0f));
  EXPECT_THAT(matrix.row(3), ElementsAre(2.0f, -1.0f));  // missing -> <unk>
  EXPECT_THAT(matrix.row(4), ElementsAre(3.0f, -4.0f));
  EXPECT_EQ(report.found, 2);
  EXPECT_THAT(report.missing, ElementsAre("nowhere"));

  EmbeddingMatrix zero = buildEmbeddingMatrix(
      vocab, vectors, {.missing = MissingWordPolicy::kZero});
  EXPECT_THAT(zero.row(3), ElementsAre(0.0f, 0.0f));
  EXPECT_THAT(zero.row(1), ElementsAre(2.0f, -1.0f));

  WordVectors unrelated(2);
  unrelated.add("zebra", std::vector<float>{1.0f, 1.0f});
  EXPECT_THAT([&] { buildEmbeddingMatrix(vocab, unrelated); },
              ThrowsMessage<std::invalid_argument>(
                  HasSubstr("none of the 3 vocabulary words")));
}

TEST(GloveTest, EmbeddingsJsonRoundTripsAndRejectsRaggedRows) {
  test::TempDir dir;
  EmbeddingMatrix matrix{2, 3, {0.0f, 0.0f, 0.0f, 0.25f, -1.5f, 1e-6f}};
  writeEmbeddingsJson(dir / "emb.json.gz", matrix);
  EXPECT_EQ(readEmbeddingsJson(dir / "emb.json.gz"), matrix);
  test::writeText(dir / "ragged.json", "[[1, 2, 3], [1, 2]]");
  EXPECT_THAT([&] { readEmbeddingsJson(dir / "ragged.json"); },
              ThrowsMessage<std::invalid_argument>(
                  AllOf(HasSubstr("ragged.json"),
                        HasSubstr("row 1 has 2 values, expected 3"))));
  test::writeText(dir / "text.json", "[[1, \"a\"]]");
  EXPECT_THAT([&] { readEmbeddingsJson(dir / "text.json"); },
              ThrowsMessage<std::invalid_argument>(
                  HasSubstr("row 0 value 1 is not a number")));
}

// The real embeddings.json.gz rebuilt from a GloVe text file holding its own
// word rows: proves the pad/unk conventions documented in Glove.h.
TEST(GloveTest, RebuildsTheRealEmbeddingMatrix) {
  auto episodes = test::realR2rSample("val_seen_sample.json.gz");
  auto embeddings = test::realR2rSample("embeddings.json.gz");
  if (!std::filesystem::exists(episodes) ||
      !std::filesystem::exists(embeddings))
    GTEST_SKIP() << "no real samples";
  Vocabulary vocab = *readEpisodes(episodes).instruction_vocab;
  EmbeddingMatrix real = readEmbeddingsJson(embeddings);
  ASSERT_EQ(real.rows, 2504);
  ASSERT_EQ(real.dim, 50);

  // a GloVe file with the real rows of every ordinary word, shuffled order
  test::TempDir dir;
  WordVectors table(real.dim);
  for (int i = vocab.size() - 1; i >= 2; --i)
    table.add(vocab.word(i), real.row(i));
  writeGloveText(dir / "glove.6B.50d.sub.txt", table);
  GloveReadOptions options;
  options.only_words.emplace(vocab.words().begin(), vocab.words().end());
  WordVectors read = readGloveText(dir / "glove.6B.50d.sub.txt", options);

  EmbeddingBuildReport report;
  EmbeddingMatrix rebuilt = buildEmbeddingMatrix(vocab, read, {}, &report);
  EXPECT_EQ(report.found, 2502);
  EXPECT_TRUE(report.missing.empty());
  ASSERT_EQ(rebuilt.rows, real.rows);
  float worst = 0.0f;
  int worstRow = -1;
  for (size_t k = 0; k < real.values.size(); ++k) {
    float diff = std::abs(rebuilt.values[k] - real.values[k]);
    if (diff > worst) {
      worst = diff;
      worstRow = static_cast<int>(k / real.dim);
    }
  }
  EXPECT_LE(worst, 1e-6f) << "row " << worstRow;
}

// =========================================================================
// the embeddings command
// =========================================================================

TEST(GloveTest, EmbeddingsCommandBuildsTheVocabularyMatrix) {
  test::TempDir dir;
  EmbeddingsCommandOptions options;
  options.glove = test::r2rFixture("tiny_glove.txt");
  options.episodes = test::r2rFixture("tiny_split.json");
  options.out = dir / "embeddings.json";
  std::ostringstream out;
  EXPECT_EQ(runEmbeddingsCommand(options, out), 0);
  EXPECT_THAT(out.str(), HasSubstr("23 x 3, 4 words found, 17 missing"));
  EmbeddingMatrix matrix = readEmbeddingsJson(dir / "embeddings.json");
  Vocabulary vocab =
      *readEpisodes(test::r2rFixture("tiny_split.json")).instruction_vocab;
  EXPECT_THAT(matrix.row(*vocab.find("walk")),
              ElementsAre(-0.5f, 0.25f, 1e-3f));
  // <unk> = mean of the, walk, stairs, turn
  EXPECT_NEAR(matrix.row(vocab.unkIndex())[0], (0.1 - 0.5 + 0.0 + 0.75) / 4,
              1e-7);
}

}  // namespace
}  // namespace vln::data
