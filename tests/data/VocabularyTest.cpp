// Tests src/data/Vocabulary.cpp: the VLN-CE tokeniser, vocabulary building,
// the instruction_vocab JSON layout and encoding, against hand-checked cases
// and the real val_seen sample.

#include "data/Vocabulary.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/Json.h"
#include "data/Episode.h"
#include "support/TestPaths.h"

namespace vln::data {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

using Tokens = std::vector<std::string>;

// =========================================================================
// tokenizer
// =========================================================================

// Expected values were produced with habitat's tokenize(sentence,
// keep=["'s"], remove=[",", "?"], regex=r"([^\w-]+)") under Python 3.11.
TEST(VocabularyTest, TokenizeMatchesVlnceOnHandCheckedSentences) {
  struct Case {
    std::string sentence;
    Tokens expected;
  };
  const std::vector<Case> cases = {
      {"Walk down the stairs, turn right.",
       {"walk", "down", "the", "stairs", "turn", "right", "."}},
      {"It's the owner's room",
       {"it", "'", "s", "the", "owner", "'", "s", "room"}},
      {"Stop at the T-intersection, then go -1 step",
       {"stop", "at", "the", "t-intersection", "then", "go", "-1", "step"}},
      {"Enter the room. (Then stop!)",
       {"enter", "the", "room", ". (", "then", "stop", "!)"}},
      {"Really?! Wait...", {"really", "!", "wait", "..."}},
      {"   ", {}},
      {"", {}},
      {"snake_case word", {"snake_case", "word"}},
      {"Go\tleft\x1cnow\u00a0ok", {"go", "left", "now", "ok"}},
      {"He said \"stop\" here", {"he", "said", "\"", "stop", "\"", "here"}},
      {"left..right", {"left", "..", "right"}},
      {"3rd floor, 90 degrees", {"3rd", "floor", "90", "degrees"}},
      {"a--b - c", {"a--b", "-", "c"}},
      {"room.'s", {"room", ". '", "s"}},
  };
  for (const Case& c : cases)
    EXPECT_EQ(tokenize(c.sentence), c.expected) << "'" << c.sentence << "'";
}

TEST(VocabularyTest, TokenizeLowercasesAndKeepsNonAsciiLetters) {
  EXPECT_EQ(tokenize("Café ÉCOLE naïve"), (Tokens{"café", "école", "naïve"}));
  EXPECT_EQ(tokenize("ÄÖÜ straße"), (Tokens{"äöü", "straße"}));
  // invalid UTF-8 bytes are kept verbatim as separators
  EXPECT_EQ(tokenize("go\xff"
                     "left"),
            (Tokens{"go", "\xff", "left"}));
}

TEST(VocabularyTest, RealSampleTokensAreReproducedExactly) {
  auto file = test::realR2rSample("val_seen_sample.json.gz");
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "no " << file;
  EpisodeDataset dataset = readEpisodes(file);
  ASSERT_TRUE(dataset.instruction_vocab.has_value());
  const Vocabulary& vocab = *dataset.instruction_vocab;
  ASSERT_EQ(dataset.episodes.size(), 12u);
  for (const Episode& episode : dataset.episodes) {
    const auto& expected = episode.instruction.instruction_tokens;
    EXPECT_EQ(vocab.encode(episode.instruction.instruction_text,
                           static_cast<int>(expected.size())),
              expected)
        << "episode " << episode.episode_id;
  }
}

// =========================================================================
// vocabulary
// =========================================================================

TEST(VocabularyTest, BuildPutsSpecialsFirstThenCodePointOrder) {
  Vocabulary vocab =
      Vocabulary::build({"Walk to the sofa, then walk left.",
                         "Zebra rug near the door", "\"Quote\" #3 (x)"});
  // '" #' is one separator run (quote, space, hash), as in VLN-CE
  EXPECT_THAT(vocab.words(),
              ElementsAre("<pad>", "<unk>", "\"", "\" #", "(", ")", ".", "3",
                          "door", "left", "near", "quote", "rug", "sofa", "the",
                          "then", "to", "walk", "x", "zebra"));
  EXPECT_EQ(vocab.padIndex(), 0);
  EXPECT_EQ(vocab.unkIndex(), 1);

  // min_count 2 keeps only the repeated words
  Vocabulary frequent =
      Vocabulary::build({"walk the walk", "the hall", "go"}, {.min_count = 2});
  EXPECT_THAT(frequent.words(), ElementsAre("<pad>", "<unk>", "the", "walk"));
  EXPECT_THAT([] { Vocabulary::build({"a"}, {.min_count = 0}); },
              ThrowsMessage<std::invalid_argument>(HasSubstr("min_count")));
}

TEST(VocabularyTest, EncodePadsTruncatesAndMapsUnknownWords) {
  Vocabulary vocab({"<pad>", "<unk>", ".", "left", "turn"});
  EXPECT_EQ(vocab.encode("Turn LEFT, now.", 6),
            (std::vector<int>{4, 3, 1, 2, 0, 0}));
  EXPECT_EQ(vocab.encode("turn left turn left", 3),
            (std::vector<int>{4, 3, 4}));
  EXPECT_EQ(vocab.encode("turn", 0), (std::vector<int>{4}));
  EXPECT_EQ(vocab.encode("turn").size(),
            static_cast<size_t>(kDefaultInstructionLength));
  EXPECT_EQ(vocab.decode({4, 3, 1, 2, 0, 0}), "turn left <unk> .");
  EXPECT_EQ(unpaddedLength({4, 3, 1, 2, 0, 0}), 4);
  EXPECT_THAT(
      [&] {
        vocab.decode({4, 9});
      },
      ThrowsMessage<std::invalid_argument>(
          HasSubstr("token 1 is 9, outside the vocabulary [0, 5)")));
  EXPECT_EQ(vocab.find("left"), 3);
  EXPECT_EQ(vocab.find("right"), std::nullopt);
  EXPECT_EQ(vocab.index("right"), vocab.unkIndex());
}

TEST(VocabularyTest, ConstructorRejectsDuplicatesAndMissingSpecials) {
  EXPECT_THAT(
      [] {
        Vocabulary({"<pad>", "<unk>", "a", "a"});
      },
      ThrowsMessage<std::invalid_argument>(
          HasSubstr("word 'a' appears twice (indices 2 and 3)")));
  EXPECT_THAT(
      [] {
        Vocabulary({"<pad>", "a"});
      },
      ThrowsMessage<std::invalid_argument>(HasSubstr("'<unk>'")));
  EXPECT_THAT(
      [] {
        Vocabulary({"<unk>", "a"});
      },
      ThrowsMessage<std::invalid_argument>(HasSubstr("'<pad>'")));
}

TEST(VocabularyTest, JsonLayoutRoundTrips) {
  Vocabulary vocab({"<pad>", "<unk>", "door", "walk"});
  nlohmann::json value = vocab.toJson();
  EXPECT_EQ(value["word_list"], value["itos"]);
  EXPECT_EQ(value["stoi"], value["word2idx_dict"]);
  EXPECT_EQ(value["stoi"]["walk"], 3);
  EXPECT_EQ(value["num_vocab"], 4);
  EXPECT_EQ(value["UNK_INDEX"], 1);
  EXPECT_EQ(value["PAD_INDEX"], 0);
  EXPECT_EQ(Vocabulary::fromJson(value, "test"), vocab);
  // word_list alone is enough
  EXPECT_EQ(Vocabulary::fromJson({{"word_list", vocab.words()}}, "test"),
            vocab);
}

TEST(VocabularyTest, FromJsonRejectsInconsistentFields) {
  const nlohmann::json good =
      Vocabulary({"<pad>", "<unk>", "door", "walk"}).toJson();
  struct Case {
    std::string key;
    nlohmann::json value;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {"word_list",
       {"<pad>", "<unk>", 3},
       "'word_list' entry 2 must be a string"},
      {"word_list", "<pad>", "'word_list' must be an array"},
      {"itos", {"<pad>", "<unk>", "walk", "door"}, "'itos' differs"},
      {"stoi",
       {{"<pad>", 0}, {"<unk>", 1}, {"door", 2}},
       "'stoi' has 3 entries but word_list has 4"},
      {"word2idx_dict",
       {{"<pad>", 0}, {"<unk>", 1}, {"door", 2}, {"walk", 2}},
       "'word2idx_dict' maps 'walk' to 2"},
      {"num_vocab", 5, "'num_vocab' is 5"},
      {"UNK_INDEX", 0, "'UNK_INDEX' is 0"},
      {"PAD_INDEX", nullptr, "'PAD_INDEX' is null"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.key);
    nlohmann::json bad = good;
    bad[c.key] = c.value;
    EXPECT_THAT(
        [&] { Vocabulary::fromJson(bad, "file.json: instruction_vocab"); },
        ThrowsMessage<std::invalid_argument>(AllOf(
            HasSubstr("file.json: instruction_vocab"), HasSubstr(c.expected))));
  }
  EXPECT_THAT([] { Vocabulary::fromJson(nlohmann::json::object(), "ctx"); },
              ThrowsMessage<std::invalid_argument>(
                  HasSubstr("ctx: field 'word_list' is missing")));
}

TEST(VocabularyTest, RealVocabularyRoundTripsExactlyAndIsSorted) {
  auto file = test::realR2rSample("val_seen_sample.json.gz");
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "no " << file;
  nlohmann::json raw = common::readJsonFile(file)["instruction_vocab"];
  Vocabulary vocab = Vocabulary::fromJson(raw, "real");
  EXPECT_EQ(vocab.size(), 2504);
  EXPECT_EQ(vocab.toJson(), raw);
  // the public vocabulary follows build()'s order: specials, then sorted
  const auto& words = vocab.words();
  EXPECT_EQ(words[0], "<pad>");
  EXPECT_EQ(words[1], "<unk>");
  EXPECT_TRUE(std::is_sorted(words.begin() + 2, words.end()));
  std::map<std::string, int64_t> counts;
  for (size_t i = 2; i < words.size(); ++i) counts[words[i]] = 1;
  EXPECT_EQ(Vocabulary::fromCounts(counts), vocab);
}

}  // namespace
}  // namespace vln::data
