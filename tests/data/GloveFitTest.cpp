// Tests src/data/GloveFit.cpp: co-occurrence counting and GloVe fitting;
// plus the `glove` command of src/data/DataCommands.cpp.

#include "data/GloveFit.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <sstream>

#include "data/DataCommands.h"
#include "data/WordVectorRows.h"
#include "support/TestPaths.h"

namespace vln::data {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

using test::row;

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
// co-occurrence counting
// =========================================================================

TEST(GloveFitTest, CooccurrencesUseHarmonicWeightsWithinSentences) {
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

TEST(GloveFitTest, FitPlacesSynonymsCloserAndLossDecreases) {
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

TEST(GloveFitTest, FitIsDeterministicBySeed) {
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

TEST(GloveFitTest, HogwildThreadsAlsoConverge) {
  GloveFitConfig config = smallConfig();
  config.threads = 2;
  GloveFitResult fit = fitGlove(synonymCorpus(), config);
  EXPECT_LT(fit.epoch_loss.back(), 0.5 * fit.epoch_loss.front());
  EXPECT_GT(cosine(fit.vectors, "sofa", "couch"),
            cosine(fit.vectors, "sofa", "car"));
}

TEST(GloveFitTest, FitRejectsBadConfigsAndDegenerateCorpora) {
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
// the glove command
// =========================================================================

TEST(GloveFitTest, GloveCommandWritesVectorsAndTheCorpusVocabularyMatrix) {
  test::TempDir dir;
  GloveCommandOptions options;
  options.corpus = test::r2rFixture("tiny_split.json");
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

}  // namespace
}  // namespace vln::data
