#include "data/Vocabulary.h"

#include <nlohmann/json.hpp>

#include <locale.h>
#include <wctype.h>

#include <algorithm>

#include "common/Check.h"

namespace vln::data {
namespace {

// =========================================================================
// UTF-8 <-> code points
// =========================================================================

// a code point, or the raw byte of an invalid sequence (kept verbatim)
struct Unit {
  char32_t code = 0;
  bool raw = false;
};

std::vector<Unit> decodeUtf8(std::string_view text) {
  std::vector<Unit> units;
  units.reserve(text.size());
  size_t i = 0;
  while (i < text.size()) {
    auto lead = static_cast<unsigned char>(text[i]);
    int extra = lead < 0x80             ? 0
                : (lead & 0xE0) == 0xC0 ? 1
                : (lead & 0xF0) == 0xE0 ? 2
                : (lead & 0xF8) == 0xF0 ? 3
                                        : -1;
    char32_t code = extra == 0   ? lead
                    : extra == 1 ? (lead & 0x1F)
                    : extra == 2 ? (lead & 0x0F)
                                 : (lead & 0x07);
    bool valid = extra >= 0 && i + static_cast<size_t>(extra) < text.size();
    for (int k = 1; valid && k <= extra; ++k) {
      auto next = static_cast<unsigned char>(text[i + k]);
      if ((next & 0xC0) != 0x80) valid = false;
      code = (code << 6) | (next & 0x3F);
    }
    // reject overlong forms, surrogates and values beyond U+10FFFF
    static constexpr char32_t kMinForLength[] = {0, 0x80, 0x800, 0x10000};
    if (valid && (code < kMinForLength[extra] || code > 0x10FFFF ||
                  (code >= 0xD800 && code <= 0xDFFF)))
      valid = false;
    if (valid) {
      units.push_back({code, false});
      i += static_cast<size_t>(extra) + 1;
    } else {
      units.push_back({lead, true});
      ++i;
    }
  }
  return units;
}

void appendUtf8(std::string& out, Unit unit) {
  char32_t c = unit.code;
  if (unit.raw || c < 0x80) {
    out.push_back(static_cast<char>(c));
  } else if (c < 0x800) {
    out.push_back(static_cast<char>(0xC0 | (c >> 6)));
    out.push_back(static_cast<char>(0x80 | (c & 0x3F)));
  } else if (c < 0x10000) {
    out.push_back(static_cast<char>(0xE0 | (c >> 12)));
    out.push_back(static_cast<char>(0x80 | ((c >> 6) & 0x3F)));
    out.push_back(static_cast<char>(0x80 | (c & 0x3F)));
  } else {
    out.push_back(static_cast<char>(0xF0 | (c >> 18)));
    out.push_back(static_cast<char>(0x80 | ((c >> 12) & 0x3F)));
    out.push_back(static_cast<char>(0x80 | ((c >> 6) & 0x3F)));
    out.push_back(static_cast<char>(0x80 | (c & 0x3F)));
  }
}

// =========================================================================
// character classes (Python 3 str semantics)
// =========================================================================

// glibc ships C.UTF-8 built in since 2.35; null when unavailable, in which
// case non-ASCII letters are treated as word characters and not lowercased
locale_t utf8Locale() {
  static const locale_t locale = ::newlocale(LC_ALL_MASK, "C.UTF-8", nullptr);
  return locale;
}

char32_t toLower(Unit unit) {
  char32_t c = unit.code;
  if (unit.raw) return c;
  if (c < 0x80) return (c >= 'A' && c <= 'Z') ? c + ('a' - 'A') : c;
  locale_t locale = utf8Locale();
  if (!locale) return c;
  return static_cast<char32_t>(::towlower_l(static_cast<wint_t>(c), locale));
}

// Python's `\w` plus '-', i.e. the complement of the split pattern [^\w-]
bool isWordChar(Unit unit) {
  char32_t c = unit.code;
  if (unit.raw) return false;
  if (c < 0x80)
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
           (c >= '0' && c <= '9') || c == '_' || c == '-';
  locale_t locale = utf8Locale();
  if (!locale) return true;
  return ::iswalnum_l(static_cast<wint_t>(c), locale) != 0;
}

// str.isspace(): the ASCII controls \t..\r and \x1c..\x1f, space, and the
// Unicode separators Python lists as whitespace
bool isSpace(Unit unit) {
  char32_t c = unit.code;
  if (unit.raw) return false;
  if (c < 0x80) return (c >= 0x09 && c <= 0x0D) || (c >= 0x1C && c <= 0x20);
  return c == 0x85 || c == 0xA0 || c == 0x1680 ||
         (c >= 0x2000 && c <= 0x200A) || c == 0x2028 || c == 0x2029 ||
         c == 0x202F || c == 0x205F || c == 0x3000;
}

}  // namespace

// =========================================================================
// tokenizer
// =========================================================================

std::vector<std::string> tokenize(std::string_view sentence) {
  // lowercase first: the keep/remove substitutions act on the lowered text
  std::vector<Unit> lowered = decodeUtf8(sentence);
  for (Unit& unit : lowered) unit.code = toLower(unit);

  // "'s" -> " 's", then drop "," and "?" (habitat's keep/remove defaults)
  std::vector<Unit> text;
  text.reserve(lowered.size() + 8);
  for (size_t i = 0; i < lowered.size(); ++i) {
    const Unit& unit = lowered[i];
    if (!unit.raw && unit.code == '\'' && i + 1 < lowered.size() &&
        !lowered[i + 1].raw && lowered[i + 1].code == 's')
      text.push_back({' ', false});
    text.push_back(unit);
  }
  std::erase_if(text, [](const Unit& unit) {
    return !unit.raw && (unit.code == ',' || unit.code == '?');
  });

  // alternate runs of [\w-] and [^\w-], each stripped; empty runs vanish
  std::vector<std::string> tokens;
  size_t begin = 0;
  while (begin < text.size()) {
    bool word = isWordChar(text[begin]);
    size_t end = begin;
    while (end < text.size() && isWordChar(text[end]) == word) ++end;
    size_t first = begin;
    size_t last = end;
    while (first < last && isSpace(text[first])) ++first;
    while (last > first && isSpace(text[last - 1])) --last;
    if (first < last) {
      std::string token;
      for (size_t k = first; k < last; ++k) appendUtf8(token, text[k]);
      tokens.push_back(std::move(token));
    }
    begin = end;
  }
  return tokens;
}

// =========================================================================
// Vocabulary
// =========================================================================

Vocabulary::Vocabulary(std::vector<std::string> words)
    : words_(std::move(words)) {
  index_.reserve(words_.size());
  for (size_t i = 0; i < words_.size(); ++i) {
    auto [it, inserted] = index_.emplace(words_[i], static_cast<int>(i));
    VLN_CHECK_ARG(inserted, "Vocabulary::Vocabulary(): word '", words_[i],
                  "' appears twice (indices ", it->second, " and ", i, ")");
  }
  auto pad = find(kPadToken);
  auto unk = find(kUnkToken);
  VLN_CHECK_ARG(pad.has_value(),
                "Vocabulary::Vocabulary(): the word list has "
                "no '",
                kPadToken, "' token (", words_.size(), " words)");
  VLN_CHECK_ARG(unk.has_value(),
                "Vocabulary::Vocabulary(): the word list has "
                "no '",
                kUnkToken, "' token (", words_.size(), " words)");
  pad_ = *pad;
  unk_ = *unk;
}

Vocabulary Vocabulary::build(const std::vector<std::string>& sentences,
                             const VocabularyBuildOptions& options) {
  std::map<std::string, int64_t> counts;
  for (const std::string& sentence : sentences)
    for (std::string& token : tokenize(sentence)) ++counts[std::move(token)];
  return fromCounts(counts, options);
}

Vocabulary Vocabulary::fromCounts(const std::map<std::string, int64_t>& counts,
                                  const VocabularyBuildOptions& options) {
  VLN_CHECK_ARG(options.min_count >= 1,
                "Vocabulary::fromCounts(): min_count must be >= 1, got ",
                options.min_count);
  // std::map orders std::string by bytes, which for UTF-8 is code point
  // order, i.e. Python's sorted()
  std::vector<std::string> words{std::string(kPadToken),
                                 std::string(kUnkToken)};
  for (const auto& [word, count] : counts)
    if (count >= options.min_count && word != kPadToken && word != kUnkToken)
      words.push_back(word);
  return Vocabulary(std::move(words));
}

Vocabulary Vocabulary::fromJson(const nlohmann::json& value,
                                std::string_view context) {
  VLN_CHECK_ARG(value.is_object(), context, ": expected a JSON object, got ",
                value.type_name());
  auto wordList = value.find("word_list");
  VLN_CHECK_ARG(wordList != value.end(), context,
                ": field 'word_list' is missing");
  VLN_CHECK_ARG(wordList->is_array(), context,
                ": field 'word_list' must be an array of strings, got ",
                wordList->type_name());
  std::vector<std::string> words;
  words.reserve(wordList->size());
  for (size_t i = 0; i < wordList->size(); ++i) {
    const auto& word = (*wordList)[i];
    VLN_CHECK_ARG(word.is_string(), context, ": field 'word_list' entry ", i,
                  " must be a string, got ", word.dump());
    words.push_back(word.get<std::string>());
  }
  Vocabulary vocab;
  try {
    vocab = Vocabulary(std::move(words));
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(
        strCat(context, ": field 'word_list': ", e.what()));
  }

  // the redundant fields VLN-CE stores must agree with word_list
  for (const char* key : {"word2idx_dict", "stoi"}) {
    auto it = value.find(key);
    if (it == value.end()) continue;
    VLN_CHECK_ARG(it->is_object(), context, ": field '", key,
                  "' must be an object, got ", it->type_name());
    VLN_CHECK_ARG(it->size() == static_cast<size_t>(vocab.size()), context,
                  ": field '", key, "' has ", it->size(),
                  " entries but word_list has ", vocab.size());
    for (const auto& [word, index] : it->items()) {
      auto expected = vocab.find(word);
      VLN_CHECK_ARG(expected.has_value() && index.is_number_integer() &&
                        index.get<int64_t>() == *expected,
                    context, ": field '", key, "' maps '", word, "' to ",
                    index.dump(), " but word_list has it at ",
                    expected ? std::to_string(*expected) : "no index");
    }
  }
  if (auto it = value.find("itos"); it != value.end())
    VLN_CHECK_ARG(*it == *wordList, context,
                  ": field 'itos' differs from word_list");
  if (auto it = value.find("num_vocab"); it != value.end())
    VLN_CHECK_ARG(it->is_number_integer() && it->get<int64_t>() == vocab.size(),
                  context, ": field 'num_vocab' is ", it->dump(),
                  " but word_list has ", vocab.size(), " words");
  for (auto [key, expected] : {std::pair{"UNK_INDEX", vocab.unkIndex()},
                               std::pair{"PAD_INDEX", vocab.padIndex()}}) {
    auto it = value.find(key);
    if (it == value.end()) continue;
    VLN_CHECK_ARG(it->is_number_integer() && it->get<int64_t>() == expected,
                  context, ": field '", key, "' is ", it->dump(),
                  " but word_list has the token at ", expected);
  }
  return vocab;
}

nlohmann::json Vocabulary::toJson() const {
  nlohmann::json stoi = nlohmann::json::object();
  for (size_t i = 0; i < words_.size(); ++i) stoi[words_[i]] = i;
  return {{"word_list", words_}, {"word2idx_dict", stoi}, {"stoi", stoi},
          {"itos", words_},      {"num_vocab", size()},   {"UNK_INDEX", unk_},
          {"PAD_INDEX", pad_}};
}

const std::string& Vocabulary::word(int index) const {
  VLN_ASSERT(index >= 0 && index < size());
  return words_[static_cast<size_t>(index)];
}

std::optional<int> Vocabulary::find(std::string_view word) const {
  auto it = index_.find(std::string(word));
  if (it == index_.end()) return std::nullopt;
  return it->second;
}

int Vocabulary::index(std::string_view word) const {
  return find(word).value_or(unk_);
}

std::vector<int> Vocabulary::encode(std::string_view sentence,
                                    int length) const {
  VLN_CHECK_ARG(size() > 0, "Vocabulary::encode(): the vocabulary is empty");
  std::vector<int> tokens;
  for (const std::string& token : tokenize(sentence))
    tokens.push_back(index(token));
  if (length > 0) tokens.resize(static_cast<size_t>(length), pad_);
  return tokens;
}

std::string Vocabulary::decode(const std::vector<int>& tokens) const {
  std::string text;
  for (size_t i = 0; i < tokens.size(); ++i) {
    int token = tokens[i];
    VLN_CHECK_ARG(token >= 0 && token < size(), "Vocabulary::decode(): token ",
                  i, " is ", token, ", outside the vocabulary [0, ", size(),
                  ")");
    if (token == pad_) break;
    if (!text.empty()) text += ' ';
    text += words_[static_cast<size_t>(token)];
  }
  return text;
}

int unpaddedLength(const std::vector<int>& tokens, int padIndex) {
  return static_cast<int>(
      std::count_if(tokens.begin(), tokens.end(),
                    [padIndex](int token) { return token != padIndex; }));
}

}  // namespace vln::data
