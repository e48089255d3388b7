#include "train/TextPretrainer.h"

#include <spdlog/spdlog.h>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <tuple>

#include "common/Check.h"
#include "common/Json.h"
#include "common/Progress.h"
#include "common/Random.h"
#include "data/RxrEpisodes.h"
#include "data/RxrTextFeatures.h"
#include "models/Policy.h"
#include "models/StateDict.h"
#include "train/PretrainCommon.h"

namespace vln::train {
namespace fs = std::filesystem;

namespace {

constexpr std::string_view kTask = "text_mlm";
// streams of common::deriveSeed(trainer.seed, .): batch order, training
// masks, held-out masks
constexpr uint64_t kOrderStream = 0x7e47'0001;
constexpr uint64_t kMaskStream = 0x7e47'0002;
constexpr uint64_t kHeldoutStream = 0x7e47'0003;

// r2r_path, with its default and "none"
fs::path r2rRoot(const ExperimentConfig& config) {
  const std::string& path = config.pretrain.text.r2r_path;
  if (path == "none") return {};
  return path.empty() ? fs::path(config.dataset.data_path) : fs::path(path);
}

// the instruction texts of the R2R-style `split` (no file: nullopt when
// `optional`, else the reader's error)
std::optional<std::vector<std::string>> r2rTexts(const fs::path& root,
                                                 const std::string& split,
                                                 bool optional) {
  const fs::path file = data::splitEpisodesPath(root, split);
  if (optional && !fs::exists(file)) return std::nullopt;
  std::vector<std::string> texts;
  for (const data::Episode& e : data::readEpisodes(file).episodes)
    texts.push_back(e.instruction.instruction_text);
  return texts;
}

// the same for the RxR-style `split` (no folder: nullopt when `optional`)
std::optional<std::vector<std::string>> rxrTexts(
    const fs::path& root, const std::string& split,
    const data::RxrFilterConfig& filter, bool optional) {
  if (optional && !fs::is_directory(root / split)) return std::nullopt;
  std::vector<std::string> texts;
  for (const data::Episode& e : data::readRxrEpisodes(root, split, filter))
    texts.push_back(e.instruction.instruction_text);
  return texts;
}

// the ids of `texts`, without the ones that have no token
std::vector<std::vector<int>> tokenIds(const data::Vocabulary& vocabulary,
                                       const std::vector<std::string>& texts,
                                       int maxTokens) {
  std::vector<std::vector<int>> ids;
  ids.reserve(texts.size());
  for (const std::string& text : texts) {
    std::vector<int> row = textTokenIds(vocabulary, text, maxTokens);
    if (!row.empty()) ids.push_back(std::move(row));
  }
  return ids;
}

// one row of the metrics
nlohmann::json scoresJson(const MlmScores& s) {
  return {{"masked_tokens", s.masked},
          {"accuracy", s.accuracy},
          {"loss", s.loss},
          {"baseline_accuracy", s.baseline_accuracy},
          {"baseline_loss", s.baseline_loss}};
}

}  // namespace

// ===========================================================================
// corpus and vocabulary
// ===========================================================================

TextCorpus readTextCorpus(const ExperimentConfig& config) {
  const TextPretrainConfig& t = config.pretrain.text;
  TextCorpus corpus;
  std::set<std::string> trainSet;
  std::set<std::string> heldoutSet;
  // each distinct non-empty text once, held-out texts seen in training
  // dropped
  auto add = [&](const std::string& source, std::vector<std::string> texts,
                 bool heldout) {
    corpus.sources.emplace_back(source, static_cast<int64_t>(texts.size()));
    for (std::string& text : texts) {
      if (data::tokenize(text).empty()) continue;
      if (!heldout) {
        if (trainSet.insert(text).second)
          corpus.train.push_back(std::move(text));
      } else if (heldoutSet.insert(text).second) {
        corpus.heldout.push_back(std::move(text));
      }
    }
  };
  const fs::path r2r = r2rRoot(config);
  if (!r2r.empty()) {
    for (const std::string& split : t.r2r_train_splits)
      add("r2r:" + split, *r2rTexts(r2r, split, /*optional=*/false),
          /*heldout=*/false);
  }
  if (!t.rxr_path.empty()) {
    for (const std::string& split : t.rxr_train_splits)
      add("rxr:" + split,
          *rxrTexts(t.rxr_path, split, t.rxr_filter, /*optional=*/false),
          /*heldout=*/false);
  }
  if (!r2r.empty()) {
    for (const std::string& split : t.r2r_heldout_splits)
      if (auto texts = r2rTexts(r2r, split, /*optional=*/true))
        add("r2r:" + split, std::move(*texts), /*heldout=*/true);
  }
  if (!t.rxr_path.empty()) {
    for (const std::string& split : t.rxr_heldout_splits)
      if (auto texts =
              rxrTexts(t.rxr_path, split, t.rxr_filter, /*optional=*/true))
        add("rxr:" + split, std::move(*texts), /*heldout=*/true);
  }
  // held-out texts that are training texts say nothing about unseen ones
  std::erase_if(corpus.heldout, [&](const std::string& text) {
    const bool seen = trainSet.count(text) > 0;
    corpus.heldout_dropped += seen ? 1 : 0;
    return seen;
  });
  VLN_CHECK_ARG(!corpus.train.empty(),
                "text_mlm: no training instruction in pretrain.text's "
                "r2r_train_splits / rxr_train_splits (r2r_path '",
                r2r.string(), "', rxr_path '", t.rxr_path, "')");
  return corpus;
}

data::Vocabulary buildTextVocabulary(const std::vector<std::string>& texts,
                                     int minCount) {
  std::vector<std::string> words =
      data::Vocabulary::build(texts, {.min_count = minCount}).words();
  words.emplace_back(kMaskToken);
  return data::Vocabulary(std::move(words));
}

std::vector<int> textTokenIds(const data::Vocabulary& vocabulary,
                              std::string_view text, int maxTokens) {
  std::vector<int> ids = vocabulary.encode(text, /*length=*/0);
  if (static_cast<int>(ids.size()) > maxTokens) ids.resize(maxTokens);
  return ids;
}

// ===========================================================================
// scores
// ===========================================================================

UnigramBaseline unigramBaseline(const std::vector<std::vector<int>>& sentences,
                                int vocabSize, int maskIndex) {
  // counts of every word (not <pad>, not <mask>), add-one smoothed
  std::vector<double> counts(static_cast<size_t>(vocabSize), 1.0);
  counts[0] = 0.0;
  counts[static_cast<size_t>(maskIndex)] = 0.0;
  for (const auto& row : sentences)
    for (int id : row) counts[static_cast<size_t>(id)] += 1.0;
  UnigramBaseline baseline;
  double total = 0.0;
  for (double c : counts) total += c;
  baseline.probability.resize(counts.size());
  for (size_t i = 0; i < counts.size(); ++i)
    baseline.probability[i] = counts[i] / total;
  baseline.most_frequent = static_cast<int>(
      std::max_element(counts.begin(), counts.end()) - counts.begin());
  return baseline;
}

MlmScores evaluateMlm(models::TextFeatureEncoder& encoder,
                      const std::vector<std::vector<int>>& sentences,
                      const UnigramBaseline& baseline, int maskIndex,
                      double probability, uint64_t seed, int batchSize) {
  VLN_ASSERT(batchSize > 0);
  // one fixed draw per sentence: every chosen token becomes <mask>
  models::MlmMaskOptions options;
  options.mask_index = maskIndex;
  options.probability = probability;
  options.replace_mask = 1.0;
  options.replace_random = 0.0;
  const bool wasTraining = encoder->is_training();
  encoder->eval();
  torch::NoGradGuard noGrad;
  const torch::Device device = encoder->tokenEmbedding->weight.device();
  MlmScores scores;
  double correct = 0.0, loss = 0.0, baseCorrect = 0.0, baseLoss = 0.0;
  for (size_t start = 0; start < sentences.size();
       start += static_cast<size_t>(batchSize)) {
    const size_t end =
        std::min(sentences.size(), start + static_cast<size_t>(batchSize));
    std::vector<torch::Tensor> inputs, labels;
    const int64_t width = static_cast<int64_t>(
        std::max_element(
            sentences.begin() + static_cast<int64_t>(start),
            sentences.begin() + static_cast<int64_t>(end),
            [](const auto& a, const auto& b) { return a.size() < b.size(); })
            ->size());
    for (size_t i = start; i < end; ++i) {
      std::mt19937_64 rng(common::deriveSeed(seed, i));
      models::MlmBatch one = models::maskTokens(
          models::padTokenRows({sentences[i]}), options, rng);
      const int64_t pad = width - one.inputs.size(1);
      inputs.push_back(torch::constant_pad_nd(one.inputs, {0, pad}, 0));
      labels.push_back(
          torch::constant_pad_nd(one.labels, {0, pad}, models::kMlmIgnore));
    }
    const torch::Tensor input = torch::cat(inputs).to(device);
    const torch::Tensor label = torch::cat(labels);
    // the encoder's predictions at the chosen tokens
    const torch::Tensor logits =
        encoder->mlmLogits(encoder->forward(input)).to(torch::kCPU);
    const torch::Tensor chosen = label.ne(models::kMlmIgnore);
    const torch::Tensor target = label.masked_select(chosen);
    const torch::Tensor picked =
        logits.index({chosen}).to(torch::kFloat64);  // [n, V]
    if (target.numel() == 0) continue;
    correct += picked.argmax(1).eq(target).sum().item<double>();
    loss += torch::nn::functional::cross_entropy(
                picked, target,
                torch::nn::functional::CrossEntropyFuncOptions().reduction(
                    torch::kSum))
                .item<double>();
    // the baseline on the same tokens
    const auto t = target.accessor<int64_t, 1>();
    for (int64_t k = 0; k < t.size(0); ++k) {
      baseCorrect += t[k] == baseline.most_frequent ? 1.0 : 0.0;
      baseLoss -= std::log(baseline.probability[static_cast<size_t>(t[k])]);
    }
    scores.masked += target.numel();
  }
  encoder->train(wasTraining);
  if (scores.masked > 0) {
    const double n = static_cast<double>(scores.masked);
    scores.accuracy = correct / n;
    scores.loss = loss / n;
    scores.baseline_accuracy = baseCorrect / n;
    scores.baseline_loss = baseLoss / n;
  }
  return scores;
}

// ===========================================================================
// feature files and the saved encoder
// ===========================================================================

int64_t writeTextFeatureFiles(models::TextFeatureEncoder& encoder,
                              const data::Vocabulary& vocabulary,
                              const std::vector<data::Episode>& episodes,
                              const fs::path& featuresDir,
                              std::string_view split) {
  // one text per file name: the roles' copies of an instruction agree
  std::map<std::tuple<int64_t, std::string>, const data::Episode*> byFile;
  for (const data::Episode& e : episodes) {
    const data::Instruction& in = e.instruction;
    VLN_CHECK_ARG(in.instruction_id && !in.language.empty(),
                  "writeTextFeatureFiles(): split '", split, "' episode ",
                  e.episode_id,
                  ": no instruction_id or language (an RxR-style episode "
                  "is needed)");
    const std::string lang(data::rxrLanguagePrefix(in.language));
    auto [it, added] = byFile.try_emplace({*in.instruction_id, lang}, &e);
    VLN_CHECK_ARG(added || it->second->instruction.instruction_text ==
                               in.instruction_text,
                  "writeTextFeatureFiles(): split '", split, "': episodes ",
                  it->second->episode_id, " and ", e.episode_id,
                  " have different texts under instruction_id ",
                  *in.instruction_id, " (", lang, ")");
  }
  const int dim = encoder->config().output_dim;
  const int maxTokens = encoder->config().max_tokens;
  for (const auto& [key, e] : byFile) {
    const std::vector<int> ids =
        textTokenIds(vocabulary, e->instruction.instruction_text, maxTokens);
    VLN_CHECK_ARG(!ids.empty(), "writeTextFeatureFiles(): split '", split,
                  "' episode ", e->episode_id, " instruction_id ",
                  std::get<0>(key), ": the instruction has no token");
    const torch::Tensor features = encoder->encodeOne(ids);
    const float* values = features.data_ptr<float>();
    data::writeRxrTextFeatures(
        data::rxrTextFeaturesPath(featuresDir, split, std::get<0>(key),
                                  e->instruction.language),
        std::vector<float>(values, values + features.numel()), dim);
  }
  return static_cast<int64_t>(byFile.size());
}

fs::path textVocabularyPath(const fs::path& encoder) {
  fs::path file = encoder;
  return file.replace_extension(".vocab.json");
}

void saveTextEncoder(models::TextFeatureEncoder& encoder,
                     const data::Vocabulary& vocabulary, const fs::path& file) {
  models::saveModule(*encoder, file);
  common::writeJsonFile(textVocabularyPath(file), vocabulary.toJson());
}

LoadedTextEncoder loadTextEncoder(const fs::path& file,
                                  const models::TextEncoderConfig& config) {
  const fs::path vocabFile = textVocabularyPath(file);
  LoadedTextEncoder loaded;
  loaded.vocabulary = data::Vocabulary::fromJson(
      common::readJsonFile(vocabFile),
      strCat("loadTextEncoder(): '", vocabFile.string(), "'"));
  VLN_CHECK_ARG(
      loaded.vocabulary.find(kMaskToken) == loaded.vocabulary.size() - 1,
      "loadTextEncoder(): '", vocabFile.string(), "': '", kMaskToken,
      "' is not the last word");
  loaded.encoder = models::TextFeatureEncoder(config, loaded.vocabulary.size());
  models::loadModule(*loaded.encoder, file);
  loaded.encoder->eval();
  return loaded;
}

// ===========================================================================
// the task
// ===========================================================================

void validateTextPretrainConfig(const ExperimentConfig& config) {
  const TextPretrainConfig& t = config.pretrain.text;
  try {
    t.encoder.validate();
    t.rxr_filter.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(strCat("text_mlm: ", e.what()));
  }
  VLN_CHECK_ARG(!t.r2r_train_splits.empty() || !t.rxr_train_splits.empty(),
                "text_mlm: pretrain.text.r2r_train_splits and "
                "rxr_train_splits are both empty");
  VLN_CHECK_ARG(t.encoder_in.empty() ||
                    (!t.rxr_path.empty() && !t.feature_splits.empty()),
                "text_mlm: pretrain.text.encoder_in only writes feature files: "
                "it needs rxr_path and feature_splits");
  VLN_CHECK_ARG(
      t.feature_splits.empty() || !t.rxr_path.empty() || t.features_dir.empty(),
      "text_mlm: pretrain.text.features_dir is set but rxr_path "
      "is empty (the feature files are written for RxR-style "
      "episodes)");
}

namespace {

// The feature files of every split of pretrain.text.feature_splits (with
// rxr_path): their folder, the count per split and in all.
struct WrittenFeatures {
  fs::path dir;
  nlohmann::json splits = nlohmann::json::object();
  int64_t files = 0;

  /// The "features" record of pretrain_metrics.json.
  nlohmann::json record(int dim) const {
    return {{"dir", dir.string()},
            {"dim", dim},
            {"files", files},
            {"splits", splits}};
  }
};

WrittenFeatures writeFeatureSplits(const TextPretrainConfig& t,
                                   models::TextFeatureEncoder& encoder,
                                   const data::Vocabulary& vocabulary) {
  WrittenFeatures out;
  if (t.rxr_path.empty() || t.feature_splits.empty()) return out;
  out.dir = t.features_dir.empty() ? fs::path(t.rxr_path) / "text_features"
                                   : fs::path(t.features_dir);
  for (const std::string& split : t.feature_splits) {
    const int64_t n = writeTextFeatureFiles(
        encoder, vocabulary,
        data::readRxrEpisodes(t.rxr_path, split, t.rxr_filter), out.dir,
        split);
    out.splits[split] = n;
    out.files += n;
    spdlog::info("{}: {} feature files in {}", kTask, n,
                 (out.dir / ("rxr_" + split)).string());
  }
  return out;
}

// pretrain.text.encoder_in: the features of an encoder trained before
void writeFeaturesOfSavedEncoder(const ExperimentConfig& config,
                                 const fs::path& runDir) {
  const TextPretrainConfig& t = config.pretrain.text;
  common::Stopwatch clock;
  PretrainRun run;
  run.config = config;
  run.runDir = runDir;
  torch::set_num_threads(config.trainer.torch_threads);
  run.openMetrics();
  LoadedTextEncoder loaded = loadTextEncoder(t.encoder_in, t.encoder);
  const WrittenFeatures written =
      writeFeatureSplits(t, loaded.encoder, loaded.vocabulary);
  nlohmann::json record = {
      {"task", kTask},
      {"seconds", clock.seconds()},
      {"encoder_in", t.encoder_in},
      {"features", written.record(t.encoder.output_dim)}};
  run.finish(record, {});
  spdlog::info("{}: {} feature files from the encoder {}, {:.1f} s", kTask,
               written.files, t.encoder_in, clock.seconds());
}

}  // namespace

void runTextMlmPretraining(const ExperimentConfig& config,
                           const fs::path& runDir) {
  validateTextPretrainConfig(config);
  VLN_CHECK_ARG(config.trainer.task == kTask,
                "runTextMlmPretraining(): trainer.task must be text_mlm, got '",
                config.trainer.task, "'");
  const TextPretrainConfig& t = config.pretrain.text;
  if (!t.encoder_in.empty()) {
    writeFeaturesOfSavedEncoder(config, runDir);
    return;
  }
  const uint64_t seed = static_cast<uint64_t>(config.trainer.seed);
  common::Stopwatch total;
  PretrainRun run;
  run.config = config;
  run.runDir = runDir;
  run.device = models::modelDevice(config.model);
  torch::set_num_threads(config.trainer.torch_threads);
  torch::manual_seed(seed);
  run.openMetrics();

  // corpus, vocabulary, baseline
  const TextCorpus corpus = readTextCorpus(config);
  const data::Vocabulary vocabulary =
      buildTextVocabulary(corpus.train, t.min_count);
  const int maskIndex = vocabulary.size() - 1;
  const int maxTokens = t.encoder.max_tokens;
  const auto train = tokenIds(vocabulary, corpus.train, maxTokens);
  const auto heldout = tokenIds(vocabulary, corpus.heldout, maxTokens);
  const UnigramBaseline baseline =
      unigramBaseline(train, vocabulary.size(), maskIndex);
  int64_t trainTokens = 0;
  for (const auto& row : train) trainTokens += static_cast<int64_t>(row.size());
  spdlog::info(
      "{}: {} training instructions ({} tokens), {} held-out ({} dropped as "
      "training texts), vocabulary {}",
      kTask, train.size(), trainTokens, heldout.size(), corpus.heldout_dropped,
      vocabulary.size());

  // the encoder and its optimizer
  models::TextFeatureEncoder encoder(t.encoder, vocabulary.size());
  encoder->to(run.device);
  torch::optim::Adam optimizer(encoder->parameters(),
                               torch::optim::AdamOptions(t.lr));
  models::MlmMaskOptions masking;
  masking.mask_index = maskIndex;
  masking.random_low = 2;
  masking.random_high = maskIndex;
  masking.probability = t.mask_probability;
  std::mt19937_64 maskRng(common::deriveSeed(seed, kMaskStream));
  NonFiniteLosses nonFinite;
  auto score = [&] {
    return evaluateMlm(encoder, heldout, baseline, maskIndex,
                       t.mask_probability,
                       common::deriveSeed(seed, kHeldoutStream), t.batch_size);
  };

  // epochs of shuffled batches
  common::Stopwatch trainClock;
  MlmScores scores;
  for (int epoch = 0; epoch < t.epochs; ++epoch) {
    encoder->train();
    const std::vector<int64_t> order =
        run.shuffledOrder(train.size(), kOrderStream + 16 * (epoch + 1));
    double epochLoss = 0.0;
    int64_t epochBatches = 0;
    for (size_t start = 0; start < order.size();
         start += static_cast<size_t>(t.batch_size)) {
      std::vector<std::vector<int>> rows;
      for (size_t i = start;
           i <
           std::min(order.size(), start + static_cast<size_t>(t.batch_size));
           ++i)
        rows.push_back(train[static_cast<size_t>(order[i])]);
      const models::MlmBatch batch =
          models::maskTokens(models::padTokenRows(rows), masking, maskRng);
      if (batch.labels.ne(models::kMlmIgnore).sum().item<int64_t>() == 0)
        continue;
      const torch::Tensor logits =
          encoder->mlmLogits(encoder->forward(batch.inputs.to(run.device)));
      const torch::Tensor loss = torch::nn::functional::cross_entropy(
          logits.reshape({-1, logits.size(2)}),
          batch.labels.reshape({-1}).to(run.device),
          torch::nn::functional::CrossEntropyFuncOptions().ignore_index(
              models::kMlmIgnore));
      const double value = loss.item<double>();
      if (!std::isfinite(value)) {
        nonFinite.skip(config, std::string(kTask), "", run.updates);
        continue;
      }
      nonFinite.inARow = 0;
      if (std::isnan(run.initialLoss)) run.initialLoss = value;
      applyUpdate(optimizer, *encoder, loss, config.trainer.grad_clip);
      ++run.updates;
      epochLoss += value;
      ++epochBatches;
      if (run.updates % config.trainer.log_every_updates == 0)
        run.metrics->write("update", {{"epoch", epoch}, {"loss", value}},
                           {{"text_mlm/loss", value}}, run.updates);
    }
    // held-out score after the epoch
    scores = score();
    const double meanLoss =
        epochBatches > 0 ? epochLoss / static_cast<double>(epochBatches) : 0.0;
    spdlog::info(
        "{}: epoch {}/{} loss {:.3f}; held-out masked accuracy {:.3f} "
        "(unigram {:.3f}), cross-entropy {:.3f} (unigram {:.3f})",
        kTask, epoch + 1, t.epochs, meanLoss, scores.accuracy,
        scores.baseline_accuracy, scores.loss, scores.baseline_loss);
    nlohmann::json record = scoresJson(scores);
    record["epoch"] = epoch + 1;
    record["train_loss"] = meanLoss;
    run.metrics->write("eval", record,
                       {{"text_mlm/heldout_accuracy", scores.accuracy},
                        {"text_mlm/heldout_loss", scores.loss},
                        {"text_mlm/train_loss", meanLoss}},
                       run.updates);
  }
  const double trainSeconds = trainClock.seconds();

  // the encoder, then the feature files
  const fs::path encoderFile =
      encoderOutputPath(config, runDir, "text_encoder.pt");
  saveTextEncoder(encoder, vocabulary, encoderFile);
  common::Stopwatch featureClock;
  const WrittenFeatures written = writeFeatureSplits(t, encoder, vocabulary);

  // pretrain_metrics.json
  nlohmann::json sources = nlohmann::json::object();
  for (const auto& [name, n] : corpus.sources) sources[name] = n;
  nlohmann::json record = {
      {"task", kTask},
      {"seconds", total.seconds()},
      {"train_seconds", trainSeconds},
      {"feature_seconds", featureClock.seconds()},
      {"updates", run.updates},
      {"initial_loss", run.initialLoss},
      {"nonfinite_losses", nonFinite.total},
      {"parameters", parameterCount(*encoder)},
      {"corpus",
       {{"sources", sources},
        {"train_instructions", train.size()},
        {"train_tokens", trainTokens},
        {"heldout_instructions", heldout.size()},
        {"heldout_dropped_as_training_texts", corpus.heldout_dropped},
        {"vocabulary", vocabulary.size()}}},
      {"heldout", scoresJson(scores)},
      {"encoder", encoderFile.string()},
      {"features", written.record(t.encoder.output_dim)}};
  run.finish(record,
             {{"text_mlm/heldout_accuracy", scores.accuracy},
              {"text_mlm/baseline_accuracy", scores.baseline_accuracy}});
  spdlog::info("{}: encoder in {}, {} feature files, {:.1f} s", kTask,
               encoderFile.string(), written.files, total.seconds());
}

}  // namespace vln::train
