#pragma once
// GloVe word vectors (Pennington, Socher and Manning, EMNLP 2014): reading
// and writing the standard text files and the R2R_VLNCE
// `embeddings.json.gz` matrix, and building that matrix for a vocabulary.
// Fitting GloVe on a corpus is GloveFit.h.
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

}  // namespace vln::data
