#pragma once
// The vlnce-data subcommands as plain functions over parsed options, so the
// binary stays a thin CLI11 layer and tests can call them directly. Each
// returns the process exit code and writes its report to `out`.

#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

#include "data/Glove.h"
#include "data/GloveFitConfig.h"

namespace vln::data {

/// `vlnce-data stats`.
struct StatsCommandOptions {
  std::filesystem::path episodes;      ///< {split}.json(.gz)
  std::filesystem::path ground_truth;  ///< {split}_gt.json(.gz); optional
  bool json = false;                   ///< print JSON instead of text
};

/// Prints the statistics of an episode file (see DatasetStats).
int runStatsCommand(const StatsCommandOptions& options, std::ostream& out);

/// `vlnce-data glove`.
struct GloveCommandOptions {
  /// An episode file (.json / .json.gz: its instruction_text values) or a
  /// plain or gzipped text file (one sentence per line).
  std::filesystem::path corpus;
  std::filesystem::path out;  ///< GloVe text file to write
  /// Optional embeddings.json(.gz) to write for a vocabulary: that of
  /// `vocab_from`, else the corpus file's instruction_vocab, else one built
  /// from the corpus with Vocabulary::build(min_count).
  std::filesystem::path embeddings_out;
  std::filesystem::path vocab_from;  ///< episode file with instruction_vocab
  GloveFitConfig fit;
};

/// Fits GloVe on the corpus and writes the vectors (and optionally the
/// embedding matrix).
int runGloveCommand(const GloveCommandOptions& options, std::ostream& out);

/// `vlnce-data embeddings`.
struct EmbeddingsCommandOptions {
  std::filesystem::path glove;     ///< GloVe text file (plain or .gz)
  std::filesystem::path episodes;  ///< episode file with instruction_vocab
  std::filesystem::path out;       ///< embeddings.json(.gz) to write
  MissingWordPolicy missing = MissingWordPolicy::kUnkRow;
};

/// Builds the [num_vocab, dim] embedding matrix of an episode file's
/// vocabulary from a GloVe table, as VLN-CE's embeddings.json.gz.
int runEmbeddingsCommand(const EmbeddingsCommandOptions& options,
                         std::ostream& out);

/// `vlnce-data rxr-merge`.
struct RxrMergeCommandOptions {
  /// RxR inference outputs (.jsonl), e.g. one per language.
  std::vector<std::filesystem::path> inputs;
  std::filesystem::path out;  ///< merged .jsonl to write
};

/// Merges RxR inference outputs into one file (see RxrPredictions.h).
int runRxrMergeCommand(const RxrMergeCommandOptions& options,
                       std::ostream& out);

/// True for names ending in .json or .json.gz (episode files).
bool isJsonPath(const std::filesystem::path& path);

/// Tokenised sentences of a corpus file: the instruction_text of every
/// episode of an episode file, or every non-empty line of a text file,
/// each through tokenize().
std::vector<std::vector<std::string>> readCorpus(
    const std::filesystem::path& file);

}  // namespace vln::data
