// Tests src/data/Glove.cpp: GloVe text files, the embeddings.json matrix
// (checked against the real R2R_VLNCE embeddings), co-occurrence counting and
// GloVe fitting; plus the `glove` and `embeddings` commands of
// src/data/DataCommands.cpp.

#include "data/Glove.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <sstream>

#include "common/FileIo.h"
#include "common/Json.h"
#include "data/DataCommands.h"
#include "data/Episode.h"
#include "support/TestPaths.h"

namespace vln::data {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

std::filesystem::path fixture(const std::string& name) {
  return test::testDataPath() / "r2r" / name;
}

std::filesystem::path realSample(const std::string& name) {
  return test::sharedFixturesPath() / "r2r_vlnce_v1-3_preprocessed" / name;
}

std::vector<float> row(const WordVectors& vectors, std::string_view word) {
  auto index = vectors.find(word);
  if (!index) return {};
  auto span = vectors.vector(*index);
  return {span.begin(), span.end()};
}

double cosine(const WordVectors& vectors, std::string_view a,
              std::string_view b) {
  auto x = row(vectors, a);
  auto y = row(vectors, b);
  double dot = 0.0, nx = 0.0, ny = 0.0;
  for (size_t k = 0; k < x.size(); ++k) {
    dot += x[k] * y[k];
    nx += x[k] * x[k];
    ny += y[k] * y[k];
  }
  return dot / std::sqrt(nx * ny);
}

// =========================================================================
// text files
// =========================================================================

TEST(GloveTest, ReadsRowsIncludingSpacedTokensAndKeepsFirstDuplicate) {
  WordVectors vectors = readGloveText(fixture("tiny_glove.txt"));
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
                          common::readFile(fixture("tiny_glove.txt")));
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
  auto episodes = realSample("val_seen_sample.json.gz");
  auto embeddings = realSample("embeddings.json.gz");
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
// co-occurrence counting
// =========================================================================

TEST(GloveTest, CooccurrencesUseHarmonicWeightsWithinSentences) {
  auto entries = countCooccurrences({{0, 1, 2}}, /*vocabSize=*/3,
                                    /*window=*/2);
  EXPECT_THAT(
      entries,
      ElementsAre(CooccurrenceEntry{0, 1, 1.0}, CooccurrenceEntry{0, 2, 0.5},
                  CooccurrenceEntry{1, 0, 1.0}, CooccurrenceEntry{1, 2, 1.0},
                  CooccurrenceEntry{2, 0, 0.5}, CooccurrenceEntry{2, 1, 1.0}));
  // a window of 1 drops the distance-2 pair; sentences never mix
  EXPECT_EQ(countCooccurrences({{0, 1, 2}}, 3, 1).size(), 4u);
  EXPECT_TRUE(countCooccurrences({{0}, {1}}, 2, 10).empty());
  // a repeated word co-occurs with itself in both directions
  EXPECT_THAT(countCooccurrences({{0, 0}}, 1, 5),
              ElementsAre(CooccurrenceEntry{0, 0, 2.0}));
  EXPECT_THAT(
      [] {
        countCooccurrences({{0, 3}}, 3, 2);
      },
      ThrowsMessage<std::invalid_argument>(
          HasSubstr("sentence 0 word 1 has id 3")));
}

// =========================================================================
// fitting
// =========================================================================

// "sofa"/"couch" occur in identical contexts (the home words) and
// "car"/"truck" in the road words. Each context word comes from the other
// group 15% of the time: GloVe fits only the non-zero co-occurrences, so with
// perfectly disjoint groups the relation between groups lives only in zeros
// the objective never sees and their relative geometry is left arbitrary.
// std::mt19937's output sequence is fixed by the standard.
std::vector<std::vector<std::string>> synonymCorpus() {
  const std::vector<std::string> groups[2] = {
      {"living", "cushion", "relax", "pillow", "blanket", "lamp"},
      {"garage", "engine", "wheel", "drive", "road", "fuel"}};
  static const char* kTargets[] = {"sofa", "couch", "car", "truck"};
  std::mt19937 rng(7);
  std::vector<std::vector<std::string>> sentences;
  for (int s = 0; s < 400; ++s) {
    int group = s % 4 < 2 ? 0 : 1;
    std::vector<std::string> sentence;
    for (int k = 0; k < 5; ++k) {
      if (k == 2) sentence.push_back(kTargets[s % 4]);
      int from = rng() % 100 < 15 ? 1 - group : group;
      sentence.push_back(groups[from][rng() % groups[from].size()]);
    }
    sentences.push_back(std::move(sentence));
  }
  return sentences;
}

GloveFitConfig smallConfig() {
  GloveFitConfig config;
  config.dim = 8;
  config.window = 3;
  config.epochs = 60;
  config.seed = 11;
  return config;
}

TEST(GloveTest, FitPlacesSynonymsCloserAndLossDecreases) {
  GloveFitResult fit = fitGlove(synonymCorpus(), smallConfig());
  ASSERT_EQ(fit.vectors.size(), 16);
  EXPECT_EQ(fit.vectors.dim(), 8);
  ASSERT_EQ(fit.epoch_loss.size(), 60u);
  EXPECT_LT(fit.epoch_loss.back(), 0.5 * fit.epoch_loss.front());
  EXPECT_LT(fit.epoch_loss.back(), fit.epoch_loss[30]);
  EXPECT_EQ(fit.skipped_updates, 0);

  double synonyms = cosine(fit.vectors, "sofa", "couch");
  double vehicles = cosine(fit.vectors, "car", "truck");
  EXPECT_GT(synonyms, 0.9);
  EXPECT_GT(vehicles, 0.9);
  for (const char* home : {"sofa", "couch"})
    for (const char* road : {"car", "truck"})
      EXPECT_LT(cosine(fit.vectors, home, road), 0.0) << home << "/" << road;

  // rows are ordered by corpus count: the four targets occur 100 times each
  for (size_t i = 1; i < fit.word_counts.size(); ++i)
    EXPECT_GE(fit.word_counts[i - 1], fit.word_counts[i]);
}

TEST(GloveTest, FitIsDeterministicBySeed) {
  auto corpus = synonymCorpus();
  GloveFitConfig config = smallConfig();
  config.epochs = 5;
  GloveFitResult a = fitGlove(corpus, config);
  GloveFitResult b = fitGlove(corpus, config);
  ASSERT_EQ(a.vectors.words(), b.vectors.words());
  for (int i = 0; i < a.vectors.size(); ++i)
    EXPECT_TRUE(std::equal(a.vectors.vector(i).begin(),
                           a.vectors.vector(i).end(),
                           b.vectors.vector(i).begin()));
  EXPECT_EQ(a.epoch_loss, b.epoch_loss);
  config.seed = 12;
  GloveFitResult c = fitGlove(corpus, config);
  EXPECT_NE(row(a.vectors, "sofa"), row(c.vectors, "sofa"));
}

TEST(GloveTest, HogwildThreadsAlsoConverge) {
  GloveFitConfig config = smallConfig();
  config.threads = 2;
  GloveFitResult fit = fitGlove(synonymCorpus(), config);
  EXPECT_LT(fit.epoch_loss.back(), 0.5 * fit.epoch_loss.front());
  EXPECT_GT(cosine(fit.vectors, "sofa", "couch"),
            cosine(fit.vectors, "sofa", "car"));
}

TEST(GloveTest, FitRejectsBadConfigsAndDegenerateCorpora) {
  GloveFitConfig config = smallConfig();
  config.dim = 0;
  EXPECT_THAT([&] { fitGlove(synonymCorpus(), config); },
              ThrowsMessage<std::invalid_argument>(
                  AllOf(HasSubstr("fitGlove()"), HasSubstr("dim"))));
  EXPECT_THAT(
      [] { fitGlove({}, GloveFitConfig{}); },
      ThrowsMessage<std::invalid_argument>(HasSubstr("need at least 2")));
  EXPECT_THAT(
      [] {
        fitGlove({{"a"}, {"b"}}, GloveFitConfig{});
      },
      ThrowsMessage<std::invalid_argument>(HasSubstr("no two words")));
}

// =========================================================================
// the glove and embeddings commands
// =========================================================================

TEST(GloveTest, GloveCommandWritesVectorsAndTheCorpusVocabularyMatrix) {
  test::TempDir dir;
  GloveCommandOptions options;
  options.corpus = fixture("tiny_split.json");
  options.out = dir / "glove.txt";
  options.embeddings_out = dir / "embeddings.json.gz";
  options.fit.dim = 5;
  options.fit.epochs = 3;
  std::ostringstream out;
  EXPECT_EQ(runGloveCommand(options, out), 0);
  EXPECT_THAT(out.str(), AllOf(HasSubstr("3 sentences"), HasSubstr("dim 5")));

  // every distinct token of the three instructions gets a vector
  WordVectors vectors = readGloveText(dir / "glove.txt");
  EXPECT_EQ(vectors.dim(), 5);
  EXPECT_TRUE(vectors.find("t-intersection").has_value());
  EXPECT_TRUE(vectors.find("owner").has_value());
  // the matrix follows the corpus file's 23-word instruction_vocab
  EmbeddingMatrix matrix = readEmbeddingsJson(dir / "embeddings.json.gz");
  EXPECT_EQ(matrix.rows, 23);
  EXPECT_EQ(matrix.dim, 5);
  EXPECT_THAT(matrix.row(0), ElementsAre(0, 0, 0, 0, 0));

  // a plain text corpus, one sentence per line
  test::writeText(dir / "corpus.txt", "Walk left.\n\nturn right\nwalk right\n");
  EXPECT_EQ(readCorpus(dir / "corpus.txt"),
            (std::vector<std::vector<std::string>>{
                {"walk", "left", "."}, {"turn", "right"}, {"walk", "right"}}));
}

TEST(GloveTest, EmbeddingsCommandBuildsTheVocabularyMatrix) {
  test::TempDir dir;
  EmbeddingsCommandOptions options;
  options.glove = fixture("tiny_glove.txt");
  options.episodes = fixture("tiny_split.json");
  options.out = dir / "embeddings.json";
  std::ostringstream out;
  EXPECT_EQ(runEmbeddingsCommand(options, out), 0);
  EXPECT_THAT(out.str(), HasSubstr("23 x 3, 4 words found, 17 missing"));
  EmbeddingMatrix matrix = readEmbeddingsJson(dir / "embeddings.json");
  Vocabulary vocab =
      *readEpisodes(fixture("tiny_split.json")).instruction_vocab;
  EXPECT_THAT(matrix.row(*vocab.find("walk")),
              ElementsAre(-0.5f, 0.25f, 1e-3f));
  // <unk> = mean of the, walk, stairs, turn
  EXPECT_NEAR(matrix.row(vocab.unkIndex())[0], (0.1 - 0.5 + 0.0 + 0.75) / 4,
              1e-7);
}

}  // namespace
}  // namespace vln::data
