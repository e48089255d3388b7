#include "data/GloveFit.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <map>
#include <numeric>
#include <thread>
#include <unordered_map>
#include <utility>

#include "common/Check.h"
#include "common/Random.h"

namespace vln::data {

// =========================================================================
// co-occurrence counting
// =========================================================================

std::vector<CooccurrenceEntry> countCooccurrences(
    const std::vector<std::vector<int>>& sentences, int vocabSize, int window) {
  VLN_CHECK_ARG(vocabSize >= 1 && window >= 1,
                "countCooccurrences(): vocabSize and window must be >= 1, "
                "got ",
                vocabSize, " and ", window);
  // a sparse hash map keyed by word * vocabSize + context keeps memory
  // proportional to the distinct pairs; entries are sorted afterwards
  std::unordered_map<int64_t, double> counts;
  for (size_t s = 0; s < sentences.size(); ++s) {
    const auto& sentence = sentences[s];
    for (size_t j = 0; j < sentence.size(); ++j) {
      int right = sentence[j];
      VLN_CHECK_ARG(right >= 0 && right < vocabSize,
                    "countCooccurrences(): sentence ", s, " word ", j,
                    " has id ", right, ", outside [0, ", vocabSize, ")");
      size_t reach = std::min(j, static_cast<size_t>(window));
      for (size_t d = 1; d <= reach; ++d) {
        int left = sentence[j - d];
        double weight = 1.0 / static_cast<double>(d);
        counts[static_cast<int64_t>(left) * vocabSize + right] += weight;
        counts[static_cast<int64_t>(right) * vocabSize + left] += weight;
      }
    }
  }
  std::vector<CooccurrenceEntry> entries;
  entries.reserve(counts.size());
  for (const auto& [key, count] : counts)
    entries.push_back({static_cast<int32_t>(key / vocabSize),
                       static_cast<int32_t>(key % vocabSize), count});
  std::sort(entries.begin(), entries.end(),
            [](const CooccurrenceEntry& a, const CooccurrenceEntry& b) {
              return a.word != b.word ? a.word < b.word : a.context < b.context;
            });
  return entries;
}

// =========================================================================
// GloVe training
// =========================================================================

namespace {

// parameters of 2V rows (words, then contexts), each dim weights + a bias
struct GloveParameters {
  int vocab = 0;
  int dim = 0;
  std::vector<double> weights;  // [2V, dim + 1]
  std::vector<double> gradsq;   // AdaGrad accumulators, same layout
  size_t offset(int row) const {
    return static_cast<size_t>(row) * static_cast<size_t>(dim + 1);
  }
};

// parameter access: relaxed atomics make Hogwild's racy reads and writes
// well-defined; the single-thread path uses plain accesses so the compiler
// can vectorise the loops
template <bool kShared>
double load(double& x) {
  if constexpr (kShared)
    return std::atomic_ref<double>(x).load(std::memory_order_relaxed);
  return x;
}
template <bool kShared>
void store(double& x, double v) {
  if constexpr (kShared)
    std::atomic_ref<double>(x).store(v, std::memory_order_relaxed);
  else
    x = v;
}

struct ChunkResult {
  double loss = 0.0;
  int64_t skipped = 0;
};

// one pass over entries[order[begin..end)], glove.c's update rule
template <bool kShared>
ChunkResult trainChunk(GloveParameters& params,
                       const std::vector<CooccurrenceEntry>& entries,
                       const std::vector<uint32_t>& order, size_t begin,
                       size_t end, const GloveFitConfig& config) {
  const int dim = params.dim;
  std::vector<double> updateWord(static_cast<size_t>(dim));
  std::vector<double> updateContext(static_cast<size_t>(dim));
  ChunkResult result;
  for (size_t n = begin; n < end; ++n) {
    const CooccurrenceEntry& entry = entries[order[n]];
    double* w = params.weights.data() + params.offset(entry.word);
    double* c =
        params.weights.data() + params.offset(params.vocab + entry.context);
    double* gw = params.gradsq.data() + params.offset(entry.word);
    double* gc =
        params.gradsq.data() + params.offset(params.vocab + entry.context);

    // weighted residual of w_i.c_j + b_i + b'_j = log X_ij
    double diff =
        load<kShared>(w[dim]) + load<kShared>(c[dim]) - std::log(entry.count);
    for (int k = 0; k < dim; ++k)
      diff += load<kShared>(w[k]) * load<kShared>(c[k]);
    double weighted =
        entry.count > config.x_max
            ? diff
            : std::pow(entry.count / config.x_max, config.alpha) * diff;
    if (!std::isfinite(weighted)) {
      ++result.skipped;
      continue;
    }
    result.loss += 0.5 * weighted * diff;

    // AdaGrad on the vectors, clipped per component; an update that turns
    // non-finite is dropped whole
    double step = config.learning_rate * weighted;
    bool finite = true;
    for (int k = 0; k < dim; ++k) {
      double gradWord = std::clamp(step * load<kShared>(c[k]),
                                   -config.grad_clip, config.grad_clip);
      double gradContext = std::clamp(step * load<kShared>(w[k]),
                                      -config.grad_clip, config.grad_clip);
      updateWord[k] = gradWord / std::sqrt(load<kShared>(gw[k]));
      updateContext[k] = gradContext / std::sqrt(load<kShared>(gc[k]));
      store<kShared>(gw[k], load<kShared>(gw[k]) + gradWord * gradWord);
      store<kShared>(gc[k], load<kShared>(gc[k]) + gradContext * gradContext);
      finite = finite && std::isfinite(updateWord[k]) &&
               std::isfinite(updateContext[k]);
    }
    if (!finite) {
      ++result.skipped;
      continue;
    }
    for (int k = 0; k < dim; ++k) {
      store<kShared>(w[k], load<kShared>(w[k]) - updateWord[k]);
      store<kShared>(c[k], load<kShared>(c[k]) - updateContext[k]);
    }
    // biases
    double biasWord = step / std::sqrt(load<kShared>(gw[dim]));
    double biasContext = step / std::sqrt(load<kShared>(gc[dim]));
    if (std::isfinite(biasWord))
      store<kShared>(w[dim], load<kShared>(w[dim]) - biasWord);
    if (std::isfinite(biasContext))
      store<kShared>(c[dim], load<kShared>(c[dim]) - biasContext);
    store<kShared>(gw[dim], load<kShared>(gw[dim]) + step * step);
    store<kShared>(gc[dim], load<kShared>(gc[dim]) + step * step);
  }
  return result;
}

}  // namespace

GloveFitResult fitGlove(const std::vector<std::vector<std::string>>& sentences,
                        const GloveFitConfig& config) {
  GloveFitConfig checked = config;
  common::checkConfig([&](common::ConfigVisitor& v) { checked.visit(v); },
                      "fitGlove()");

  // vocabulary by descending count, ties by code point (deterministic)
  std::map<std::string, int64_t> counts;
  for (const auto& sentence : sentences)
    for (const std::string& token : sentence) ++counts[token];
  std::vector<std::pair<std::string, int64_t>> vocab;
  for (const auto& [word, count] : counts)
    if (count >= config.min_count) vocab.emplace_back(word, count);
  std::stable_sort(
      vocab.begin(), vocab.end(),
      [](const auto& a, const auto& b) { return a.second > b.second; });
  VLN_CHECK_ARG(vocab.size() >= 2, "fitGlove(): the corpus has ", vocab.size(),
                " word(s) with count >= min_count ", config.min_count, " in ",
                sentences.size(), " sentences; need at least 2");
  std::unordered_map<std::string, int> ids;
  for (size_t i = 0; i < vocab.size(); ++i)
    ids.emplace(vocab[i].first, static_cast<int>(i));
  const int vocabSize = static_cast<int>(vocab.size());

  // dropped words vanish from the stream, so windows close over them
  std::vector<std::vector<int>> idSentences;
  idSentences.reserve(sentences.size());
  for (const auto& sentence : sentences) {
    std::vector<int> idSentence;
    for (const std::string& token : sentence)
      if (auto it = ids.find(token); it != ids.end())
        idSentence.push_back(it->second);
    idSentences.push_back(std::move(idSentence));
  }
  std::vector<CooccurrenceEntry> entries =
      countCooccurrences(idSentences, vocabSize, config.window);
  VLN_CHECK_ARG(!entries.empty(), "fitGlove(): no two words co-occur in the ",
                sentences.size(), " sentences");
  VLN_CHECK_ARG(entries.size() < (size_t{1} << 32),
                "fitGlove(): too many co-occurrence entries (", entries.size(),
                ")");

  // glove.c's initialisation: uniform in [-0.5, 0.5] / dim, accumulators 1
  common::SplitMix64 rng{static_cast<uint64_t>(config.seed)};
  GloveParameters params;
  params.vocab = vocabSize;
  params.dim = config.dim;
  params.weights.resize(params.offset(2 * vocabSize));
  params.gradsq.assign(params.weights.size(), 1.0);
  for (double& weight : params.weights)
    weight = (rng.uniform() - 0.5) / config.dim;

  GloveFitResult result;
  result.cooccurrence_entries = static_cast<int64_t>(entries.size());
  std::vector<uint32_t> order(entries.size());
  std::iota(order.begin(), order.end(), 0u);
  const size_t threads =
      std::min(static_cast<size_t>(config.threads), entries.size());
  spdlog::info(
      "fitGlove(): {} words, {} co-occurrence entries, dim {}, {} "
      "epochs, {} thread(s)",
      vocabSize, entries.size(), config.dim, config.epochs, threads);
  for (int epoch = 0; epoch < config.epochs; ++epoch) {
    // Fisher-Yates with the seeded generator
    for (size_t i = order.size() - 1; i > 0; --i)
      std::swap(order[i], order[rng.next() % (i + 1)]);

    ChunkResult total;
    if (threads == 1) {
      total =
          trainChunk<false>(params, entries, order, 0, order.size(), config);
    } else {
      // Hogwild: contiguous slices of the shuffle, lock-free shared params
      std::vector<ChunkResult> parts(threads);
      std::vector<std::jthread> workers;
      for (size_t t = 0; t < threads; ++t) {
        size_t begin = order.size() * t / threads;
        size_t end = order.size() * (t + 1) / threads;
        workers.emplace_back([&, t, begin, end] {
          parts[t] =
              trainChunk<true>(params, entries, order, begin, end, config);
        });
      }
      workers.clear();
      for (const ChunkResult& part : parts) {
        total.loss += part.loss;
        total.skipped += part.skipped;
      }
    }
    result.skipped_updates += total.skipped;
    result.epoch_loss.push_back(total.loss /
                                static_cast<double>(entries.size()));
    spdlog::info("fitGlove(): epoch {}/{} loss {:.6f}", epoch + 1,
                 config.epochs, result.epoch_loss.back());
  }

  // the saved vector is word + context (glove.c's default model 2)
  result.vectors = WordVectors(config.dim);
  std::vector<float> vector(static_cast<size_t>(config.dim));
  for (int i = 0; i < vocabSize; ++i) {
    const double* w = params.weights.data() + params.offset(i);
    const double* c = params.weights.data() + params.offset(vocabSize + i);
    for (int k = 0; k < config.dim; ++k)
      vector[static_cast<size_t>(k)] = static_cast<float>(w[k] + c[k]);
    result.vectors.add(vocab[static_cast<size_t>(i)].first, vector);
    result.word_counts.push_back(vocab[static_cast<size_t>(i)].second);
  }
  return result;
}

}  // namespace vln::data
