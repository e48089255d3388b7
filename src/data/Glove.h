#pragma once
// GloVe word vectors (Pennington, Socher and Manning, EMNLP 2014): reading
// the standard text files, the R2R_VLNCE `embeddings.json.gz` matrix, building
// that matrix for a vocabulary, and fitting GloVe on a corpus.
//
// The embedding matrix follows the public VLN-CE file, checked row by row
// against the real embeddings.json.gz (2504 x 50, glove.6B.50d values):
//  - the "<pad>" row is all zeros;
//  - the "<unk>" row is the mean of the rows of every other vocabulary word
//    found in the GloVe table (the real file's UNK row equals the mean of
//    rows 2..2503 to float precision);
//  - every other word takes its GloVe row. In the real file every one of the
//    2502 words has a glove.6B row (all are exact 5-significant-digit GloVe
//    values), so what VLN-CE does for a word missing from GloVe cannot be
//    observed. We give such words the "<unk>" row by default (the encoder
//    then treats them exactly like the tokeniser's unknown words, and the
//    embeddings stay frozen in VLN-CE so a random row would only add noise);
//    MissingWordPolicy::kZero is the alternative.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "common/Config.h"
#include "data/Vocabulary.h"

namespace vln::data {

// =========================================================================
// word vectors
// =========================================================================

/// A table of words and their vectors, all of one dimension.
class WordVectors {
 public:
  WordVectors() = default;
  /// An empty table of `dim`-dimensional vectors (dim >= 1).
  explicit WordVectors(int dim);

  /// Vector size.
  int dim() const { return dim_; }
  /// Number of words.
  int size() const { return static_cast<int>(words_.size()); }
  /// Appends `word` with `vector` (dim() values). Returns false and keeps
  /// the existing row when `word` is already present.
  bool add(std::string word, std::span<const float> vector);
  /// Row index of `word`, or std::nullopt.
  std::optional<int> find(std::string_view word) const;
  /// Word of row `index` (in [0, size())).
  const std::string& word(int index) const;
  /// Vector of row `index`: dim() floats.
  std::span<const float> vector(int index) const;
  /// All words in row order.
  const std::vector<std::string>& words() const { return words_; }

 private:
  int dim_ = 0;
  std::vector<std::string> words_;
  std::vector<float> values_;  // [size(), dim()] row-major
  std::unordered_map<std::string, int> index_;
};

/// Options of readGloveText().
struct GloveReadOptions {
  /// Expected vector size; 0 infers it from the first row.
  int dim = 0;
  /// When set, only these words are kept (reading the 2.2M-word 840B file
  /// for a 2.5k-word vocabulary then needs a few MB instead of 2.6 GB).
  std::optional<std::unordered_set<std::string>> only_words;
};

/// Reads a GloVe text file (plain or gzip): one row per line, `word v1 ...
/// vN`, fields separated by single spaces. The last N fields of a line are
/// the vector and everything before them is the word, so the tokens of
/// glove.840B that contain spaces (". . .", "at name@domain.com") are read
/// whole; a repeated word keeps its first row; a word2vec-style "<count>
/// <dim>" first line (dim >= 2) is skipped; empty lines and rows whose word
/// is empty are ignored. Throws
/// std::runtime_error when the file cannot be read and
/// std::invalid_argument naming the file and the 1-based line for a row
/// with fewer than N values, with more than N numeric values, or with a
/// value that is not a finite number.
WordVectors readGloveText(const std::filesystem::path& file,
                          const GloveReadOptions& options = {});

/// Atomically writes `vectors` in the GloVe text format (gzip when the name
/// ends in .gz); values use the shortest decimal form that reads back to
/// the same float.
void writeGloveText(const std::filesystem::path& file,
                    const WordVectors& vectors);

// =========================================================================
// the embedding matrix of a vocabulary
// =========================================================================

/// One embedding row per vocabulary index.
struct EmbeddingMatrix {
  int rows = 0;
  int dim = 0;
  std::vector<float> values;  ///< [rows, dim] row-major float32

  /// Row `index` (dim floats).
  std::span<const float> row(int index) const;
  bool operator==(const EmbeddingMatrix&) const = default;
};

/// Reads an R2R_VLNCE embeddings file (.json or .json.gz): a JSON list of
/// rows in vocabulary order. Throws std::invalid_argument naming the file
/// and the row for ragged rows or non-numeric values.
EmbeddingMatrix readEmbeddingsJson(const std::filesystem::path& file);

/// Atomically writes `matrix` as a JSON list of rows (gzip for .gz).
void writeEmbeddingsJson(const std::filesystem::path& file,
                         const EmbeddingMatrix& matrix);

/// What the matrix holds for a word missing from the GloVe table.
enum class MissingWordPolicy {
  kUnkRow,  ///< the "<unk>" row (mean of the found rows), the default
  kZero,    ///< zeros
};

/// Options of buildEmbeddingMatrix().
struct EmbeddingBuildOptions {
  MissingWordPolicy missing = MissingWordPolicy::kUnkRow;
};

/// What buildEmbeddingMatrix() found.
struct EmbeddingBuildReport {
  int found = 0;                     ///< words with a GloVe row
  std::vector<std::string> missing;  ///< words without one (vocab order)
};

/// The [vocabulary.size(), vectors.dim()] matrix VLN-CE feeds its
/// instruction encoder (see the file comment for the pad/unk/missing rows).
/// Throws std::invalid_argument when no vocabulary word has a GloVe row.
EmbeddingMatrix buildEmbeddingMatrix(const Vocabulary& vocabulary,
                                     const WordVectors& vectors,
                                     const EmbeddingBuildOptions& options = {},
                                     EmbeddingBuildReport* report = nullptr);

// =========================================================================
// fitting GloVe
// =========================================================================

/// Hyper-parameters of fitGlove(); defaults are the GloVe paper's.
struct GloveFitConfig {
  int dim = 50;                 ///< vector size
  int window = 10;              ///< symmetric context window, words each side
  int min_count = 1;            ///< rarer words are dropped from the corpus
  double x_max = 100.0;         ///< weighting cutoff x_max of f(x)
  double alpha = 0.75;          ///< weighting exponent of f(x)
  double learning_rate = 0.05;  ///< AdaGrad initial learning rate
  int epochs = 25;              ///< passes over the co-occurrence entries
  double grad_clip = 100.0;     ///< per-component gradient clip (as glove.c)
  int64_t seed = 1;             ///< initialisation and shuffling seed
  int threads = 1;              ///< > 1 trains Hogwild (not deterministic)

  void visit(common::ConfigVisitor& v) {
    v.field("dim", dim, "Vector size", common::inRange(1, 4096));
    v.field("window", window,
            "Symmetric context window (words each side); a pair at "
            "distance d adds 1/d",
            common::inRange(1, 1000));
    v.field("min_count", min_count, "Words rarer than this are dropped",
            common::atLeast(1));
    v.field("x_max", x_max, "Cutoff of the weighting f(x) = (x/x_max)^alpha",
            common::inRange(1e-6, 1e12));
    v.field("alpha", alpha, "Exponent of the weighting f(x)",
            common::inRange(0.0, 10.0));
    v.field("learning_rate", learning_rate, "AdaGrad initial learning rate",
            common::inRange(1e-9, 10.0));
    v.field("epochs", epochs, "Passes over the co-occurrence entries",
            common::inRange(1, 100000));
    v.field("grad_clip", grad_clip, "Per-component gradient clip",
            common::inRange(1e-9, 1e12));
    v.field("seed", seed, "Initialisation and shuffling seed");
    v.field("threads", threads,
            "Training threads; > 1 is Hogwild and not deterministic",
            common::inRange(1, 256));
  }
  bool operator==(const GloveFitConfig&) const = default;
};

/// One non-zero entry X_ij of the co-occurrence matrix.
struct CooccurrenceEntry {
  int32_t word = 0;
  int32_t context = 0;
  double count = 0.0;  ///< sum of 1/distance over the co-occurrences
  bool operator==(const CooccurrenceEntry&) const = default;
};

/// The co-occurrence matrix of `sentences` (word ids in [0, vocabSize)):
/// every ordered pair at distance 1 <= d <= window within one sentence adds
/// 1/d to X[word][context] and to X[context][word] (windows never cross
/// sentences, as glove's cooccur never crosses lines). Entries are sorted
/// by (word, context).
std::vector<CooccurrenceEntry> countCooccurrences(
    const std::vector<std::vector<int>>& sentences, int vocabSize, int window);

/// The fitted vectors and the training record.
struct GloveFitResult {
  /// Word + context vector per word, words by descending corpus count
  /// (ties by code point), as glove's vocab_count orders them.
  WordVectors vectors;
  std::vector<int64_t> word_counts;  ///< corpus count per row of `vectors`
  /// Mean weighted loss 0.5 f(X_ij) (w_i.c_j + b_i + b'_j - log X_ij)^2
  /// over the entries, per epoch, measured before each update.
  std::vector<double> epoch_loss;
  int64_t cooccurrence_entries = 0;
  int64_t skipped_updates = 0;  ///< non-finite updates that were dropped
};

/// Fits GloVe on tokenised `sentences` by weighted least squares with
/// f(x) = min(1, (x/x_max)^alpha) and AdaGrad, as the reference glove.c:
/// parameters start uniform in [-0.5, 0.5] / dim, squared-gradient
/// accumulators at 1, and the entries are visited in a fresh seeded shuffle
/// each epoch. Deterministic for a given seed when threads == 1. Throws
/// std::invalid_argument on an invalid config or a corpus without any
/// co-occurring pair.
GloveFitResult fitGlove(const std::vector<std::vector<std::string>>& sentences,
                        const GloveFitConfig& config);

}  // namespace vln::data
