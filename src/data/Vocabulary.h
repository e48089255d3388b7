#pragma once
// The instruction vocabulary of R2R_VLNCE files and the tokeniser that turns
// an instruction into the padded index sequence stored in
// `instruction_tokens`.
//
// The tokeniser reproduces VLN-CE's (habitat.datasets.utils.tokenize with
// VocabDict.tokenize_and_index's defaults keep=["'s"], remove=[",", "?"] and
// the split pattern `([^\w-]+)`), which is what produced the public files:
//   1. lowercase the sentence;
//   2. replace every "'s" by " 's";
//   3. delete every "," and "?";
//   4. split into maximal runs of word characters ([\w-]: letters, digits,
//      '_' and '-') and runs of everything else, keeping both kinds;
//   5. strip whitespace from both ends of every run and drop empty runs.
// So "-" stays inside words ("t-intersection", "-1"), "'" becomes its own
// token ("it's" -> "it", "'", "s"), and a punctuation run keeps its inner
// spaces ("room. (" -> "room", ". ("). This differs from the discrete R2R
// Tokenizer.split_sentence (pattern `(\W+)`), which splits on "-" and breaks
// punctuation runs into single characters; on the real val_seen sample only
// the VLN-CE rule reproduces the stored tokens.
//
// Unicode: ASCII behaves exactly as Python 3's str.lower(), `\w` and
// str.strip(). Other code points are classified and lowercased with glibc's
// C.UTF-8 tables (simple case mapping), which agree with Python for letters
// and digits. Bytes that are not valid UTF-8 count as one non-word character
// each and are kept verbatim.

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace vln::data {

/// Padding token; always index 0 in vocabularies built here and in VLN-CE.
inline constexpr std::string_view kPadToken = "<pad>";
/// Unknown-word token; index 1 in vocabularies built here and in VLN-CE.
inline constexpr std::string_view kUnkToken = "<unk>";
/// Length of `instruction_tokens` in R2R_VLNCE files (right-padded).
inline constexpr int kDefaultInstructionLength = 200;

/// Splits `sentence` (UTF-8) into lowercase tokens with VLN-CE's rule (see
/// the file comment).
std::vector<std::string> tokenize(std::string_view sentence);

/// Options of Vocabulary::build().
struct VocabularyBuildOptions {
  /// Words occurring fewer times in the corpus are left out (map to <unk>).
  int min_count = 1;
};

/// An ordered word list with O(1) lookups in both directions. Index 0 is
/// "<pad>" and index 1 is "<unk>" for every vocabulary this module builds;
/// vocabularies read from files must contain both tokens (anywhere).
class Vocabulary {
 public:
  /// An empty vocabulary (size 0); only useful as a placeholder.
  Vocabulary() = default;
  /// A vocabulary of `words` in this order. Throws std::invalid_argument on
  /// a duplicate word or when "<pad>" or "<unk>" is missing.
  explicit Vocabulary(std::vector<std::string> words);

  /// The VLN-CE vocabulary of a corpus: "<pad>", "<unk>", then every token
  /// of tokenize(sentence) seen at least `min_count` times, sorted by
  /// Unicode code point (Python's sorted(), which is how the public
  /// instruction_vocab is ordered).
  static Vocabulary build(const std::vector<std::string>& sentences,
                          const VocabularyBuildOptions& options = {});
  /// Same as build() from precomputed token counts.
  static Vocabulary fromCounts(const std::map<std::string, int64_t>& counts,
                               const VocabularyBuildOptions& options = {});

  /// Reads an `instruction_vocab` object (word_list, word2idx_dict, stoi,
  /// itos, num_vocab, UNK_INDEX, PAD_INDEX). Only word_list is required; the
  /// other fields, when present, must agree with it. `context` prefixes
  /// errors (e.g. "readEpisodes(): 'x.json.gz': instruction_vocab").
  static Vocabulary fromJson(const nlohmann::json& value,
                             std::string_view context);
  /// The `instruction_vocab` object with all seven fields, as VLN-CE
  /// writes it.
  nlohmann::json toJson() const;

  /// Number of words (num_vocab).
  int size() const { return static_cast<int>(words_.size()); }
  /// Word at `index`; `index` must be in [0, size()).
  const std::string& word(int index) const;
  /// All words in index order (word_list / itos).
  const std::vector<std::string>& words() const { return words_; }
  /// Index of `word`, or std::nullopt when it is not in the vocabulary.
  std::optional<int> find(std::string_view word) const;
  /// Index of `word`, or unkIndex() when it is not in the vocabulary.
  int index(std::string_view word) const;
  /// Index of "<pad>" (PAD_INDEX).
  int padIndex() const { return pad_; }
  /// Index of "<unk>" (UNK_INDEX).
  int unkIndex() const { return unk_; }

  /// Token indices of tokenize(sentence), unknown words mapped to
  /// unkIndex(), right-padded with padIndex() to `length` entries. Longer
  /// instructions are truncated to their first `length` tokens (the public
  /// data has none longer than 200). `length` <= 0 disables padding and
  /// truncation.
  std::vector<int> encode(std::string_view sentence,
                          int length = kDefaultInstructionLength) const;
  /// The words of `tokens` joined by single spaces, stopping at the first
  /// padIndex(). Indices outside [0, size()) throw std::invalid_argument.
  std::string decode(const std::vector<int>& tokens) const;

  bool operator==(const Vocabulary& other) const {
    return words_ == other.words_;
  }

 private:
  std::vector<std::string> words_;
  std::unordered_map<std::string, int> index_;
  int pad_ = -1;
  int unk_ = -1;
};

/// Number of entries of `tokens` that are not `padIndex` (the instruction
/// length without padding).
int unpaddedLength(const std::vector<int>& tokens, int padIndex = 0);

}  // namespace vln::data
