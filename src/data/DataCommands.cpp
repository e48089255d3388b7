#include "data/DataCommands.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <map>
#include <optional>

#include "common/Check.h"
#include "common/FileIo.h"
#include "data/DatasetStats.h"
#include "data/Episode.h"
#include "data/GloveFit.h"
#include "data/GroundTruth.h"
#include "data/RxrPredictions.h"

namespace vln::data {

bool isJsonPath(const std::filesystem::path& path) {
  std::string name = path.filename().string();
  auto endsWith = [&](std::string_view suffix) {
    return name.size() >= suffix.size() &&
           name.compare(name.size() - suffix.size(), suffix.size(), suffix) ==
               0;
  };
  return endsWith(".json") || endsWith(".json.gz");
}

std::vector<std::vector<std::string>> readCorpus(
    const std::filesystem::path& file) {
  std::vector<std::vector<std::string>> sentences;
  if (isJsonPath(file)) {
    for (const Episode& episode : readEpisodes(file).episodes)
      sentences.push_back(tokenize(episode.instruction.instruction_text));
    return sentences;
  }
  std::string text = common::readFile(file);
  size_t begin = 0;
  while (begin < text.size()) {
    size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    auto tokens = tokenize(std::string_view(text).substr(begin, end - begin));
    if (!tokens.empty()) sentences.push_back(std::move(tokens));
    begin = end + 1;
  }
  return sentences;
}

// =========================================================================
// stats
// =========================================================================

int runStatsCommand(const StatsCommandOptions& options, std::ostream& out) {
  EpisodeDataset dataset = readEpisodes(options.episodes);
  std::optional<GroundTruth> groundTruth;
  if (!options.ground_truth.empty())
    groundTruth = readGroundTruth(options.ground_truth);
  DatasetStats stats =
      computeDatasetStats(dataset, groundTruth ? &*groundTruth : nullptr);
  if (options.json) {
    out << datasetStatsToJson(stats).dump(2) << '\n';
  } else {
    out << "file: " << options.episodes.string() << '\n'
        << formatDatasetStats(stats);
  }
  return 0;
}

// =========================================================================
// glove
// =========================================================================

int runGloveCommand(const GloveCommandOptions& options, std::ostream& out) {
  VLN_CHECK_ARG(!options.out.empty(), "runGloveCommand(): --out is required");
  auto sentences = readCorpus(options.corpus);
  GloveFitResult fit = fitGlove(sentences, options.fit);
  writeGloveText(options.out, fit.vectors);
  out << "corpus: " << options.corpus.string() << " (" << sentences.size()
      << " sentences)\n"
      << "words: " << fit.vectors.size() << ", dim " << fit.vectors.dim()
      << ", co-occurrence entries " << fit.cooccurrence_entries << '\n'
      << "loss: epoch 1 " << fit.epoch_loss.front() << ", epoch "
      << fit.epoch_loss.size() << ' ' << fit.epoch_loss.back() << '\n';
  if (fit.skipped_updates > 0)
    out << "skipped non-finite updates: " << fit.skipped_updates << '\n';
  out << "wrote " << options.out.string() << '\n';
  if (options.embeddings_out.empty()) return 0;

  // the vocabulary whose rows the matrix holds
  std::optional<Vocabulary> vocab;
  if (!options.vocab_from.empty()) {
    vocab = readEpisodes(options.vocab_from).instruction_vocab;
    VLN_CHECK_ARG(vocab.has_value(), "runGloveCommand(): '",
                  options.vocab_from.string(), "' has no instruction_vocab");
  } else if (isJsonPath(options.corpus)) {
    vocab = readEpisodes(options.corpus).instruction_vocab;
  }
  if (!vocab) {
    std::map<std::string, int64_t> counts;
    for (const auto& sentence : sentences)
      for (const std::string& token : sentence) ++counts[token];
    vocab =
        Vocabulary::fromCounts(counts, {.min_count = options.fit.min_count});
  }
  EmbeddingBuildReport report;
  EmbeddingMatrix matrix =
      buildEmbeddingMatrix(*vocab, fit.vectors, {}, &report);
  writeEmbeddingsJson(options.embeddings_out, matrix);
  out << "embeddings: " << matrix.rows << " x " << matrix.dim << ", "
      << report.found << " words found, " << report.missing.size()
      << " missing; wrote " << options.embeddings_out.string() << '\n';
  return 0;
}

// =========================================================================
// embeddings
// =========================================================================

int runEmbeddingsCommand(const EmbeddingsCommandOptions& options,
                         std::ostream& out) {
  EpisodeDataset dataset = readEpisodes(options.episodes);
  VLN_CHECK_ARG(dataset.instruction_vocab.has_value(),
                "runEmbeddingsCommand(): '", options.episodes.string(),
                "' has no instruction_vocab");
  const Vocabulary& vocab = *dataset.instruction_vocab;
  GloveReadOptions read;
  read.only_words.emplace(vocab.words().begin(), vocab.words().end());
  WordVectors vectors = readGloveText(options.glove, read);
  EmbeddingBuildReport report;
  EmbeddingMatrix matrix = buildEmbeddingMatrix(
      vocab, vectors, {.missing = options.missing}, &report);
  writeEmbeddingsJson(options.out, matrix);
  out << "embeddings: " << matrix.rows << " x " << matrix.dim << ", "
      << report.found << " words found, " << report.missing.size()
      << " missing\n";
  const size_t shown = std::min<size_t>(report.missing.size(), 20);
  for (size_t i = 0; i < shown; ++i)
    out << "  missing: " << report.missing[i] << '\n';
  if (shown < report.missing.size())
    out << "  ... " << report.missing.size() - shown << " more\n";
  out << "wrote " << options.out.string() << '\n';
  return 0;
}

// =========================================================================
// rxr-merge
// =========================================================================

int runRxrMergeCommand(const RxrMergeCommandOptions& options,
                       std::ostream& out) {
  VLN_CHECK_ARG(!options.out.empty(),
                "runRxrMergeCommand(): --out is required");
  const size_t lines = mergeRxrPredictionFiles(options.out, options.inputs);
  out << "merged " << options.inputs.size() << " files, " << lines
      << " instructions; wrote " << options.out.string() << '\n';
  return 0;
}

}  // namespace vln::data
