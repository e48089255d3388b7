#pragma once
// Text encoder pretraining (trainer.task = text_mlm): the stand-in for the
// BERT whose per-instruction features RxR ships. A small transformer
// (models/TextFeatureEncoder.h) learns the instructions of the embedded
// world as a masked language model, and its per-token outputs are written
// in RxR's layout,
//   <features_dir>/rxr_{split}/{instruction_id:06}_{lang}_text_features.npz
// (array `features`, [tokens, output_dim] float32, one row per token of
// data::tokenize()), so the RxR pipeline reads them exactly as the real
// files (data/RxrTextFeatures.h).
//
// Corpus (pretrain.text): the instruction texts of the R2R-style splits
// r2r_train_splits under r2r_path (default dataset.data_path: the embedded
// world's train and train_aug) and of the RxR-style splits rxr_train_splits
// under rxr_path (data::readRxrEpisodes with rxr_filter), each distinct text
// once. The vocabulary is data::Vocabulary::build() of the training texts
// (min_count) plus "<mask>" at the end. Held-out texts come from
// r2r_heldout_splits and rxr_heldout_splits (missing splits skipped); a
// held-out text that is also a training text is dropped (and counted), so
// the held-out accuracy is on unseen instructions.
//
// Training: Adam(lr), batches of batch_size instructions in an order
// shuffled per epoch, BERT's masking (mask_probability of the tokens; 80%
// <mask>, 10% random word, 10% unchanged), cross-entropy on the chosen
// tokens. Held-out score after every epoch: every held-out token is chosen
// with mask_probability (a fixed draw per instruction) and replaced by
// <mask>; accuracy and cross-entropy of the encoder against the unigram
// baseline (the most frequent training word; word frequencies with add-one
// smoothing for the cross-entropy).
//
// Writes, in the run directory: metrics.jsonl (and tb/), pretrain_metrics.json
// and the encoder (encoderOutputPath(config, runDir, "text_encoder.pt"),
// with its vocabulary beside it, textVocabularyPath()); then, with rxr_path,
// the feature file of every instruction of feature_splits (each written
// atomically; a rerun overwrites the same names).
//
// Determinism: weights, batches and masks derive from trainer.seed; with
// the same trainer.torch_threads a run writes the same features. Each
// instruction is encoded alone (models::TextFeatureEncoder::encodeOne()), so
// its features do not depend on the other instructions of a split.
//
// Reads: pretrain.text.*, pretrain.encoder_out, trainer.seed,
// trainer.torch_threads, trainer.grad_clip, trainer.max_nonfinite_updates,
// trainer.log_every_updates, dataset.data_path, model.device and
// output.tensorboard.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "data/Episode.h"
#include "data/Vocabulary.h"
#include "models/TextFeatureEncoder.h"
#include "train/ExperimentConfig.h"

namespace vln::train {

/// The masked-token word of the text encoder's vocabulary (last index).
inline constexpr std::string_view kMaskToken = "<mask>";

/// The instruction texts of a text_mlm run.
struct TextCorpus {
  std::vector<std::string> train;    ///< distinct training texts
  std::vector<std::string> heldout;  ///< distinct held-out texts not in train
  int64_t heldout_dropped = 0;       ///< held-out texts dropped: also in train
  /// "<kind>:<split>" -> texts read (before removing duplicates).
  std::vector<std::pair<std::string, int64_t>> sources;
};

/// Reads the corpus of config.pretrain.text (see the file comment). Throws
/// std::runtime_error for a missing training split and std::invalid_argument
/// when there is no training text at all.
TextCorpus readTextCorpus(const ExperimentConfig& config);

/// Vocabulary::build(texts, min_count) with "<mask>" appended.
data::Vocabulary buildTextVocabulary(const std::vector<std::string>& texts,
                                     int minCount);

/// The ids of tokenize(text) (unknown words -> <unk>), cut to `maxTokens`.
std::vector<int> textTokenIds(const data::Vocabulary& vocabulary,
                              std::string_view text, int maxTokens);

/// The unigram reference of the held-out score.
struct UnigramBaseline {
  /// [vocab] add-one smoothed frequencies of the training words (0 for
  /// <pad> and <mask>).
  std::vector<double> probability;
  int most_frequent = 1;  ///< the most frequent training word
};

/// The baseline of `sentences` (ids, no padding) over `vocabSize` ids where
/// `maskIndex` is never a word.
UnigramBaseline unigramBaseline(const std::vector<std::vector<int>>& sentences,
                                int vocabSize, int maskIndex);

/// Held-out masked-token scores of the encoder and of the baseline.
struct MlmScores {
  int64_t masked = 0;  ///< tokens predicted
  double accuracy = 0.0;
  double loss = 0.0;  ///< mean cross-entropy, nats per token
  double baseline_accuracy = 0.0;
  double baseline_loss = 0.0;
};

/// Masks each of `sentences` (ids, no padding) with its own draw from
/// common::deriveSeed(seed, index) (probability, all chosen tokens ->
/// `maskIndex`), then scores `encoder` in eval mode in batches of
/// `batchSize` and the baseline on the same tokens.
MlmScores evaluateMlm(models::TextFeatureEncoder& encoder,
                      const std::vector<std::vector<int>>& sentences,
                      const UnigramBaseline& baseline, int maskIndex,
                      double probability, uint64_t seed, int batchSize);

/// Writes the features of every instruction of `episodes` (which carry
/// instruction_id and language) to data::rxrTextFeaturesPath(featuresDir,
/// split, id, language) with data::writeRxrTextFeatures(); the guide's and
/// the follower's copy of an instruction share one file. Returns the files
/// written. Throws std::invalid_argument naming the split and the episode
/// for an episode without id or language, an instruction without tokens,
/// or two different texts under one file name.
int64_t writeTextFeatureFiles(models::TextFeatureEncoder& encoder,
                              const data::Vocabulary& vocabulary,
                              const std::vector<data::Episode>& episodes,
                              const std::filesystem::path& featuresDir,
                              std::string_view split);

/// The vocabulary file beside an encoder file: "x.pt" -> "x.vocab.json".
std::filesystem::path textVocabularyPath(const std::filesystem::path& encoder);

/// Saves the encoder (models::saveModule) and its vocabulary
/// (Vocabulary::toJson() at textVocabularyPath()), both atomically.
void saveTextEncoder(models::TextFeatureEncoder& encoder,
                     const data::Vocabulary& vocabulary,
                     const std::filesystem::path& file);

/// A saved encoder and its vocabulary.
struct LoadedTextEncoder {
  models::TextFeatureEncoder encoder{nullptr};
  data::Vocabulary vocabulary;
};

/// Loads what saveTextEncoder() wrote into an encoder of `config` (strict:
/// shapes must match). Throws naming the file.
LoadedTextEncoder loadTextEncoder(const std::filesystem::path& file,
                                  const models::TextEncoderConfig& config);

/// The checks of pretrain.text the YAML bounds cannot (encoder sizes, some
/// training split, feature splits needing rxr_path). Throws
/// std::invalid_argument naming the key.
void validateTextPretrainConfig(const ExperimentConfig& config);

/// trainer.task = text_mlm: trains, scores, saves and writes the features
/// (see the file comment). Expects logging set up; sets LibTorch's thread
/// count and seed itself.
void runTextMlmPretraining(const ExperimentConfig& config,
                           const std::filesystem::path& runDir);

}  // namespace vln::train
