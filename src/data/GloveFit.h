#pragma once
// Fitting GloVe word vectors (Pennington, Socher and Manning, EMNLP 2014) on
// a tokenised corpus, as the reference glove.c does: the co-occurrence
// matrix of the corpus, then weighted least squares with AdaGrad. Reading
// and writing vectors is Glove.h.

#include <cstdint>
#include <string>
#include <vector>

#include "data/Glove.h"
#include "data/GloveFitConfig.h"

namespace vln::data {

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
