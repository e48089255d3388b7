#include "data/Glove.h"

#include <zlib.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <memory>

#include "common/Check.h"
#include "common/FileIo.h"
#include "common/Json.h"

namespace vln::data {
namespace {

// =========================================================================
// streaming line reader (plain or gzip; zlib reads both transparently)
// =========================================================================

struct GzCloser {
  void operator()(gzFile file) const { gzclose(file); }
};
using GzFilePtr = std::unique_ptr<gzFile_s, GzCloser>;

class LineReader {
 public:
  explicit LineReader(const std::filesystem::path& file)
      : name_(file.string()) {
    handle_.reset(gzopen(name_.c_str(), "rb"));
    VLN_CHECK_IO(handle_ != nullptr, "readGloveText(): cannot open '", name_,
                 "'");
    gzbuffer(handle_.get(), 1 << 20);
  }

  // next line without its '\n'; false at the end of the file
  bool next(std::string& line) {
    line.clear();
    while (true) {
      size_t newline = buffer_.find('\n', position_);
      if (newline != std::string::npos) {
        line.append(buffer_, position_, newline - position_);
        position_ = newline + 1;
        return true;
      }
      line.append(buffer_, position_);
      buffer_.clear();
      position_ = 0;
      if (!fill()) return !line.empty();
    }
  }

 private:
  bool fill() {
    buffer_.resize(1 << 20);
    int n = gzread(handle_.get(), buffer_.data(),
                   static_cast<unsigned>(buffer_.size()));
    if (n < 0) {
      int code = 0;
      const char* message = gzerror(handle_.get(), &code);
      throw std::runtime_error(
          strCat("readGloveText(): cannot read '", name_, "': ", message));
    }
    buffer_.resize(static_cast<size_t>(n));
    if (n == 0) {
      // gzread reports a truncated stream only through gzerror
      int code = 0;
      const char* message = gzerror(handle_.get(), &code);
      VLN_CHECK_IO(code != Z_BUF_ERROR, "readGloveText(): '", name_,
                   "' is a truncated gzip stream");
      VLN_CHECK_IO(code == Z_OK, "readGloveText(): '", name_,
                   "' is corrupt: ", message);
    }
    return n > 0;
  }

  std::string name_;
  GzFilePtr handle_;
  std::string buffer_;
  size_t position_ = 0;
};

// whole-field float parse; false unless the field is a finite number
bool parseFloat(std::string_view field, float& value) {
  if (field.empty()) return false;
  const char* begin = field.data();
  if (*begin == '+') ++begin;
  auto [end, error] =
      std::from_chars(begin, field.data() + field.size(), value);
  return error == std::errc() && end == field.data() + field.size() &&
         std::isfinite(value);
}

bool parseInt(std::string_view field, int64_t& value) {
  auto [end, error] =
      std::from_chars(field.data(), field.data() + field.size(), value);
  return !field.empty() && error == std::errc() &&
         end == field.data() + field.size();
}

std::vector<std::string_view> splitSpaces(std::string_view line) {
  std::vector<std::string_view> fields;
  size_t begin = 0;
  while (true) {
    size_t space = line.find(' ', begin);
    fields.push_back(line.substr(begin, space - begin));
    if (space == std::string_view::npos) break;
    begin = space + 1;
  }
  return fields;
}

void appendFloat(std::string& out, float value) {
  char buffer[32];
  auto [end, error] = std::to_chars(buffer, buffer + sizeof(buffer), value);
  VLN_ASSERT(error == std::errc());
  out.append(buffer, end);
}

}  // namespace

// =========================================================================
// WordVectors
// =========================================================================

WordVectors::WordVectors(int dim) : dim_(dim) {
  VLN_CHECK_ARG(dim >= 1, "WordVectors::WordVectors(): dim must be >= 1, got ",
                dim);
}

bool WordVectors::add(std::string word, std::span<const float> vector) {
  VLN_CHECK_ARG(static_cast<int>(vector.size()) == dim_,
                "WordVectors::add(): word '", word, "' has ", vector.size(),
                " values, expected ", dim_);
  auto [it, inserted] = index_.emplace(word, size());
  if (!inserted) return false;
  words_.push_back(std::move(word));
  values_.insert(values_.end(), vector.begin(), vector.end());
  return true;
}

std::optional<int> WordVectors::find(std::string_view word) const {
  auto it = index_.find(std::string(word));
  if (it == index_.end()) return std::nullopt;
  return it->second;
}

const std::string& WordVectors::word(int index) const {
  VLN_ASSERT(index >= 0 && index < size());
  return words_[static_cast<size_t>(index)];
}

std::span<const float> WordVectors::vector(int index) const {
  VLN_ASSERT(index >= 0 && index < size());
  return {values_.data() + static_cast<size_t>(index) * dim_,
          static_cast<size_t>(dim_)};
}

// =========================================================================
// GloVe text files
// =========================================================================

// Word vectors beyond this size are not word vectors (GloVe has 300,
// word2vec releases at most a few thousand); bounds what a header allocates.
constexpr int64_t kMaxGloveDim = 65536;

WordVectors readGloveText(const std::filesystem::path& file,
                          const GloveReadOptions& options) {
  VLN_CHECK_ARG(options.dim >= 0, "readGloveText(): dim must be >= 0, got ",
                options.dim);
  VLN_CHECK_IO(std::filesystem::is_regular_file(file), "readGloveText(): '",
               file.string(), "' does not exist");
  LineReader reader(file);
  WordVectors vectors;
  int dim = options.dim;
  std::vector<float> row;
  std::string line;
  int64_t lineNumber = 0;
  while (reader.next(line)) {
    ++lineNumber;
    std::string_view text(line);
    while (!text.empty() &&
           (text.back() == '\r' || text.back() == ' ' || text.back() == '\t'))
      text.remove_suffix(1);
    if (text.empty()) continue;
    auto where = [&] {
      return strCat("readGloveText(): '", file.string(), "' line ", lineNumber);
    };

    // a word2vec "<count> <dim>" header may open the file; it is not a row
    // (a 1-d first row such as "7 3" looks the same: pass dim = 1 for such
    // files)
    if (vectors.dim() == 0) {
      auto fields = splitSpaces(text);
      int64_t count = 0;
      int64_t headerDim = 0;
      if (fields.size() == 2 && parseInt(fields[0], count) &&
          parseInt(fields[1], headerDim) && headerDim >= 2 &&
          (dim == 0 || headerDim == dim)) {
        // a row of that many values is allocated before any is read
        VLN_CHECK_ARG(headerDim <= kMaxGloveDim, where(),
                      ": the word2vec header declares ", headerDim,
                      " dimensions, more than ", kMaxGloveDim);
        dim = static_cast<int>(headerDim);
        vectors = WordVectors(dim);
        continue;
      }
      // otherwise the first row fixes the dimension unless it was given
      VLN_CHECK_ARG(fields.size() >= 2, where(),
                    ": expected 'word v1 ... vN', got '", text.substr(0, 80),
                    "'");
      if (dim == 0) dim = static_cast<int>(fields.size()) - 1;
    }
    if (vectors.dim() == 0) vectors = WordVectors(dim);

    // peel the last `dim` fields off the end; the rest is the word
    row.resize(static_cast<size_t>(dim));
    size_t end = text.size();
    for (int k = dim - 1; k >= 0; --k) {
      size_t space =
          end == 0 ? std::string_view::npos : text.rfind(' ', end - 1);
      VLN_CHECK_ARG(space != std::string_view::npos, where(),
                    ": ragged row, expected a word and ", dim, " values, got ",
                    std::count(text.begin(), text.end(), ' '),
                    " values after '", text.substr(0, text.find(' ')), "'");
      std::string_view field = text.substr(space + 1, end - space - 1);
      VLN_CHECK_ARG(parseFloat(field, row[static_cast<size_t>(k)]), where(),
                    ": value ", k + 1, " is not a finite number, got '",
                    field.substr(0, 40), "'");
      end = space;
    }
    std::string_view word = text.substr(0, end);
    // a spaced word whose last piece is a number is a row with extra values
    if (size_t space = word.rfind(' '); space != std::string_view::npos) {
      float extra = 0.0f;
      VLN_CHECK_ARG(!parseFloat(word.substr(space + 1), extra), where(),
                    ": ragged row, more than ", dim, " values for word '",
                    word.substr(0, word.find(' ')), "'");
    }
    // glove.840B has a few rows whose word is empty; nothing can look them up
    if (word.empty()) continue;
    if (options.only_words && !options.only_words->contains(std::string(word)))
      continue;
    vectors.add(std::string(word), row);
  }
  VLN_CHECK_ARG(dim > 0, "readGloveText(): '", file.string(),
                "' has no vectors");
  if (vectors.dim() == 0) vectors = WordVectors(dim);
  return vectors;
}

void writeGloveText(const std::filesystem::path& file,
                    const WordVectors& vectors) {
  std::string text;
  text.reserve(static_cast<size_t>(vectors.size()) *
               (static_cast<size_t>(vectors.dim()) * 11 + 16));
  for (int i = 0; i < vectors.size(); ++i) {
    const std::string& word = vectors.word(i);
    VLN_CHECK_ARG(!word.empty() && word.find('\n') == std::string::npos,
                  "writeGloveText(): '", file.string(), "': word ", i,
                  " is empty or contains a newline");
    text += word;
    for (float value : vectors.vector(i)) {
      text += ' ';
      appendFloat(text, value);
    }
    text += '\n';
  }
  common::writeFileAtomic(file, text);
}

// =========================================================================
// embedding matrices
// =========================================================================

std::span<const float> EmbeddingMatrix::row(int index) const {
  VLN_ASSERT(index >= 0 && index < rows);
  return {values.data() + static_cast<size_t>(index) * dim,
          static_cast<size_t>(dim)};
}

EmbeddingMatrix readEmbeddingsJson(const std::filesystem::path& file) {
  nlohmann::json root = common::readJsonFile(file);
  std::string where = strCat("readEmbeddingsJson(): '", file.string(), "'");
  VLN_CHECK_ARG(root.is_array() && !root.empty(), where,
                ": expected a non-empty list of rows, got ", root.type_name());
  EmbeddingMatrix matrix;
  matrix.rows = static_cast<int>(root.size());
  for (size_t r = 0; r < root.size(); ++r) {
    const auto& row = root[r];
    VLN_CHECK_ARG(row.is_array() && !row.empty(), where, ": row ", r,
                  " must be a non-empty list of numbers, got ",
                  row.dump().substr(0, 80));
    if (r == 0) {
      matrix.dim = static_cast<int>(row.size());
      matrix.values.reserve(root.size() * row.size());
    }
    VLN_CHECK_ARG(static_cast<int>(row.size()) == matrix.dim, where, ": row ",
                  r, " has ", row.size(), " values, expected ", matrix.dim);
    for (size_t c = 0; c < row.size(); ++c) {
      VLN_CHECK_ARG(row[c].is_number(), where, ": row ", r, " value ", c,
                    " is not a number, got ", row[c].dump());
      matrix.values.push_back(row[c].get<float>());
    }
  }
  return matrix;
}

void writeEmbeddingsJson(const std::filesystem::path& file,
                         const EmbeddingMatrix& matrix) {
  VLN_CHECK_ARG(
      matrix.values.size() == static_cast<size_t>(matrix.rows) * matrix.dim,
      "writeEmbeddingsJson(): '", file.string(), "': ", matrix.values.size(),
      " values for a ", matrix.rows, " x ", matrix.dim, " matrix");
  nlohmann::json root = nlohmann::json::array();
  for (int r = 0; r < matrix.rows; ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (float value : matrix.row(r)) row.push_back(static_cast<double>(value));
    root.push_back(std::move(row));
  }
  common::writeJsonFile(file, root);
}

EmbeddingMatrix buildEmbeddingMatrix(const Vocabulary& vocabulary,
                                     const WordVectors& vectors,
                                     const EmbeddingBuildOptions& options,
                                     EmbeddingBuildReport* report) {
  VLN_CHECK_ARG(vocabulary.size() > 0 && vectors.dim() > 0,
                "buildEmbeddingMatrix(): empty vocabulary (", vocabulary.size(),
                " words) or vectors (dim ", vectors.dim(), ")");
  const int dim = vectors.dim();
  EmbeddingMatrix matrix;
  matrix.rows = vocabulary.size();
  matrix.dim = dim;
  matrix.values.assign(static_cast<size_t>(matrix.rows) * dim, 0.0f);
  auto rowOf = [&](int index) {
    return matrix.values.begin() + static_cast<ptrdiff_t>(index) * dim;
  };

  // copy the known rows and accumulate their mean in double
  EmbeddingBuildReport found;
  std::vector<double> sum(static_cast<size_t>(dim), 0.0);
  std::vector<int> missing;
  for (int i = 0; i < vocabulary.size(); ++i) {
    if (i == vocabulary.padIndex() || i == vocabulary.unkIndex()) continue;
    auto row = vectors.find(vocabulary.word(i));
    if (!row) {
      missing.push_back(i);
      found.missing.push_back(vocabulary.word(i));
      continue;
    }
    auto source = vectors.vector(*row);
    std::copy(source.begin(), source.end(), rowOf(i));
    for (int k = 0; k < dim; ++k) sum[static_cast<size_t>(k)] += source[k];
    ++found.found;
  }
  VLN_CHECK_ARG(found.found > 0, "buildEmbeddingMatrix(): none of the ",
                vocabulary.size() - 2,
                " vocabulary words has a GloVe vector (wrong file?)");

  // <unk> is the mean of the found rows; missing words copy it if asked
  auto unk = rowOf(vocabulary.unkIndex());
  for (int k = 0; k < dim; ++k)
    unk[k] = static_cast<float>(sum[static_cast<size_t>(k)] / found.found);
  if (options.missing == MissingWordPolicy::kUnkRow)
    for (int i : missing) std::copy(unk, unk + dim, rowOf(i));
  if (report) *report = std::move(found);
  return matrix;
}

}  // namespace vln::data
