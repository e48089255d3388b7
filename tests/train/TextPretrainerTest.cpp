// trainer.task = text_mlm (src/train/TextPretrainer.cpp): the corpus, the
// baseline, a tiny masked-LM run on a toy corpus with structure, and the
// feature files it writes as RxR's reader (and numpy) read them.

#include "train/TextPretrainer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "common/Json.h"
#include "data/RxrTextFeatures.h"
#include "support/TestPaths.h"
#include "train/TextCorpusTestUtil.h"

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// a text_mlm run on the toy corpus, a few seconds on 2 cores
ExperimentConfig toyConfig(const test::ToyCorpus& corpus,
                           const fs::path& features) {
  ExperimentConfig config;
  config.trainer.task = "text_mlm";
  config.trainer.seed = 3;
  config.trainer.torch_threads = 1;
  config.output.tensorboard = false;
  TextPretrainConfig& t = config.pretrain.text;
  t.r2r_path = corpus.r2r.string();
  t.r2r_train_splits = {"train"};
  t.r2r_heldout_splits = {"val_unseen"};
  t.rxr_path = corpus.rxr.string();
  t.rxr_train_splits = {"train"};
  t.rxr_heldout_splits = {"val_unseen"};
  t.feature_splits = {"train", "val_unseen"};
  t.features_dir = features.string();
  t.epochs = 12;
  t.batch_size = 16;
  t.lr = 3e-3;
  t.mask_probability = 0.25;
  t.encoder.hidden_size = 32;
  t.encoder.layers = 2;
  t.encoder.heads = 4;
  t.encoder.ff_size = 64;
  t.encoder.dropout = 0.0;
  t.encoder.max_tokens = 64;
  return config;
}

std::string readBytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(TextPretrainerTest, CorpusVocabularyAndBaseline) {
  vln::test::TempDir dir;
  const test::ToyCorpus toy = test::writeToyCorpus(dir.path());
  const ExperimentConfig config = toyConfig(toy, dir / "features");
  const TextCorpus corpus = readTextCorpus(config);
  // 288 sentences, every 5th held out; R2R and RxR copies (and the
  // follower's repeats) count once
  EXPECT_EQ(corpus.train.size(), 230u);
  EXPECT_EQ(corpus.heldout.size(), 58u);
  EXPECT_EQ(corpus.heldout_dropped, 0);
  ASSERT_EQ(corpus.sources.size(), 4u);
  EXPECT_EQ(corpus.sources[1],
            std::make_pair(std::string("rxr:train"), int64_t{240}));

  const data::Vocabulary vocabulary = buildTextVocabulary(corpus.train, 1);
  EXPECT_EQ(vocabulary.word(0), "<pad>");
  EXPECT_EQ(vocabulary.word(vocabulary.size() - 1), kMaskToken);
  const std::vector<int> ids = textTokenIds(vocabulary, corpus.train[0], 5);
  EXPECT_EQ(vocabulary.decode(ids), "walk past the red chair");

  // "the" is the most frequent word: 4 of the 21 tokens of each sentence
  std::vector<std::vector<int>> rows;
  for (const auto& text : corpus.train)
    rows.push_back(textTokenIds(vocabulary, text, 64));
  const UnigramBaseline baseline =
      unigramBaseline(rows, vocabulary.size(), vocabulary.size() - 1);
  EXPECT_EQ(vocabulary.word(baseline.most_frequent), "the");
  EXPECT_EQ(baseline.probability[0], 0.0);
  EXPECT_EQ(baseline.probability.back(), 0.0);
  double sum = 0.0;
  for (double p : baseline.probability) sum += p;
  EXPECT_NEAR(sum, 1.0, 1e-12);

  // a held-out text that is also a training text is dropped
  ExperimentConfig overlap = config;
  overlap.pretrain.text.r2r_heldout_splits = {"train"};
  overlap.pretrain.text.rxr_heldout_splits = {"val_unseen", "missing"};
  const TextCorpus dropped = readTextCorpus(overlap);
  EXPECT_EQ(dropped.heldout.size(), 58u);
  EXPECT_EQ(dropped.heldout_dropped, 230);
}

TEST(TextPretrainerTest, TinyRunBeatsTheUnigramBaselineAndWritesRxrFiles) {
  vln::test::TempDir dir;
  const test::ToyCorpus toy = test::writeToyCorpus(dir.path());
  const ExperimentConfig config = toyConfig(toy, dir / "features");
  runTextMlmPretraining(config, dir / "run");

  // held-out masked words: far above the unigram baseline
  const nlohmann::json metrics =
      common::readJsonFile(dir / "run" / "pretrain_metrics.json");
  const nlohmann::json& heldout = metrics["heldout"];
  EXPECT_EQ(metrics["task"], "text_mlm");
  EXPECT_GT(heldout["masked_tokens"].get<int64_t>(), 100);
  EXPECT_LT(heldout["baseline_accuracy"].get<double>(), 0.3);
  EXPECT_GT(heldout["accuracy"].get<double>(),
            heldout["baseline_accuracy"].get<double>() + 0.3)
      << metrics.dump(2);
  EXPECT_LT(heldout["loss"].get<double>(),
            heldout["baseline_loss"].get<double>());
  EXPECT_EQ(metrics["features"]["files"], 288);

  // one file per instruction, read back as RxR's [512, 768] block
  for (const auto& [split, id, language] : toy.rxr_instructions) {
    const fs::path file =
        data::rxrTextFeaturesPath(dir / "features", split, id, language);
    ASSERT_TRUE(fs::exists(file)) << file;
  }
  // a Hindi instruction: its file is named "hi"
  const auto& [split, id, language] = toy.rxr_instructions[0];
  ASSERT_EQ(language, "hi-IN");
  EXPECT_EQ(data::rxrTextFeaturesPath(dir / "features", split, id, language)
                .filename(),
            "001001_hi_text_features.npz");
  const data::RxrTextFeatures loaded =
      data::loadRxrTextFeatures(dir / "features", split, id, language);
  EXPECT_EQ(loaded.valid_tokens, 21);  // the toy sentences' length
  EXPECT_EQ(loaded.values.size(), 512u * 768u);
  for (int row = 0; row < 512; ++row) {
    double norm = 0.0;
    for (int c = 0; c < 768; ++c)
      norm += std::abs(loaded.values[static_cast<size_t>(row) * 768 + c]);
    if (row < 21)
      EXPECT_GT(norm, 0.0) << row;
    else
      ASSERT_EQ(norm, 0.0) << row;
  }

  // the saved encoder reproduces the file
  LoadedTextEncoder encoder = loadTextEncoder(dir / "run" / "text_encoder.pt",
                                              config.pretrain.text.encoder);
  const std::vector<std::string> sentences = test::toySentences();
  const torch::Tensor again = encoder.encoder->encodeOne(textTokenIds(
      encoder.vocabulary, sentences[static_cast<size_t>(id - 1000)], 512));
  EXPECT_TRUE(torch::equal(
      again,
      torch::from_blob(const_cast<float*>(loaded.values.data()), {21, 768})));

  // a second run with the same seed writes the same bytes
  ExperimentConfig rerun = config;
  rerun.pretrain.text.features_dir = (dir / "features2").string();
  runTextMlmPretraining(rerun, dir / "run2");
  const fs::path a =
      data::rxrTextFeaturesPath(dir / "features", split, id, language);
  const fs::path b =
      data::rxrTextFeaturesPath(dir / "features2", split, id, language);
  EXPECT_EQ(readBytes(a), readBytes(b));
}

TEST(TextPretrainerTest, SavedEncoderWritesTheFeaturesWithoutTraining) {
  vln::test::TempDir dir;
  const test::ToyCorpus toy = test::writeToyCorpus(dir.path());
  const ExperimentConfig config = toyConfig(toy, dir / "features");
  runTextMlmPretraining(config, dir / "run");

  // pretrain.text.encoder_in: the same files from the saved encoder
  ExperimentConfig featuresOnly = config;
  featuresOnly.pretrain.text.encoder_in =
      (dir / "run" / "text_encoder.pt").string();
  featuresOnly.pretrain.text.features_dir = (dir / "again").string();
  runTextMlmPretraining(featuresOnly, dir / "features_run");
  const nlohmann::json metrics =
      common::readJsonFile(dir / "features_run" / "pretrain_metrics.json");
  EXPECT_EQ(metrics["features"]["files"], 288);
  EXPECT_FALSE(metrics.contains("heldout"));  // nothing trained or scored
  for (const auto& [split, id, language] : toy.rxr_instructions)
    EXPECT_EQ(
        readBytes(data::rxrTextFeaturesPath(dir / "features", split, id, language)),
        readBytes(data::rxrTextFeaturesPath(dir / "again", split, id, language)))
        << split << " " << id;

  // it only writes features: without rxr_path it is a config error
  ExperimentConfig noRxr = featuresOnly;
  noRxr.pretrain.text.rxr_path.clear();
  noRxr.pretrain.text.features_dir.clear();
  EXPECT_THAT([&] { validateTextPretrainConfig(noRxr); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("pretrain.text.encoder_in")));
  // a missing encoder file is named
  ExperimentConfig missing = featuresOnly;
  missing.pretrain.text.encoder_in = (dir / "nope.pt").string();
  EXPECT_THAT([&] { runTextMlmPretraining(missing, dir / "r3"); },
              ::testing::Throws<std::exception>(::testing::Property(
                  &std::exception::what, HasSubstr("nope"))));
}

TEST(TextPretrainerTest, NumpyReadsTheFeatureFiles) {
  std::string output;
  if (vln::test::runCommand("/usr/bin/python3 -c 'import numpy' 2>&1",
                            &output) != 0)
    GTEST_SKIP() << "no /usr/bin/python3 with numpy";
  vln::test::TempDir dir;
  torch::manual_seed(0);
  models::TextEncoderConfig config;
  config.hidden_size = 16;
  config.heads = 2;
  config.layers = 1;
  config.ff_size = 16;
  models::TextFeatureEncoder encoder(config, 9);
  const data::Vocabulary vocabulary =
      buildTextVocabulary({"go left then right now"}, 1);
  data::Episode e = test::toyEpisode(1, "go left then right");
  e.instruction.instruction_id = 42;
  e.instruction.language = "en-IN";
  ASSERT_EQ(
      writeTextFeatureFiles(encoder, vocabulary, {e}, dir / "f", "val_seen"),
      1);
  const fs::path file =
      dir / "f" / "rxr_val_seen" / "000042_en_text_features.npz";
  const torch::Tensor expected =
      encoder->encodeOne(textTokenIds(vocabulary, "go left then right", 512));
  ASSERT_EQ(vln::test::runCommand(
                "/usr/bin/python3 -c \"import numpy as np; "
                "a = np.load('" +
                    file.string() +
                    "')['features']; "
                    "print(a.dtype, a.shape, repr(float(a[1, 5])))\" 2>&1",
                &output),
            0)
      << output;
  EXPECT_THAT(output, HasSubstr("float32 (4, 768)"));
  EXPECT_NEAR(std::stod(output.substr(output.rfind(' ') + 1)),
              expected[1][5].item<double>(), 1e-7);
}

TEST(TextPretrainerTest, FeatureFileErrors) {
  vln::test::TempDir dir;
  models::TextEncoderConfig config;
  config.hidden_size = 16;
  config.heads = 2;
  config.layers = 1;
  config.ff_size = 16;
  config.output_dim = 8;
  models::TextFeatureEncoder encoder(config, 9);
  const data::Vocabulary vocabulary = buildTextVocabulary({"go left"}, 1);
  data::Episode a = test::toyEpisode(1, "go left");
  a.instruction.instruction_id = 7;
  a.instruction.language = "en-US";
  // an R2R-style episode has no id or language
  try {
    writeTextFeatureFiles(encoder, vocabulary, {test::toyEpisode(2, "go")},
                          dir / "f", "train");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("episode 2"));
    EXPECT_THAT(e.what(), HasSubstr("instruction_id"));
  }
  // two texts under one file name
  data::Episode b = a;
  b.episode_id = 3;
  b.instruction.instruction_text = "go right";
  b.instruction.language = "en-IN";
  try {
    writeTextFeatureFiles(encoder, vocabulary, {a, b}, dir / "f", "train");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("different texts"));
  }
  // no token at all
  data::Episode empty = a;
  empty.instruction.instruction_text = " , ";
  EXPECT_THROW(
      writeTextFeatureFiles(encoder, vocabulary, {empty}, dir / "f", "train"),
      std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir / "f" / "rxr_train"));
}

TEST(TextPretrainerTest, ConfigChecks) {
  ExperimentConfig config;
  config.trainer.task = "text_mlm";
  config.pretrain.text.encoder.heads = 5;
  EXPECT_THROW(validateTextPretrainConfig(config), std::invalid_argument);
  config.pretrain.text.encoder.heads = 4;
  config.pretrain.text.features_dir = "somewhere";
  try {
    validateTextPretrainConfig(config);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("rxr_path"));
  }
  config.pretrain.text.features_dir.clear();
  config.pretrain.text.r2r_path = "/nonexistent";
  EXPECT_THROW(readTextCorpus(config), std::runtime_error);
}

}  // namespace
}  // namespace vln::train
