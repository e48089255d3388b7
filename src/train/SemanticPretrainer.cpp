#include "train/SemanticPretrainer.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <numeric>
#include <random>
#include <string>

#include "common/Check.h"
#include "common/Json.h"
#include "common/Progress.h"
#include "common/Random.h"
#include "common/ThreadPool.h"
#include "models/Policy.h"
#include "models/StateDict.h"
#include "sim/Simulator.h"
#include "train/Checkpoint.h"
#include "train/MetricsLog.h"
#include "train/PretrainCommon.h"
#include "train/PretrainTasks.h"
#include "train/TrainingSchedule.h"
#include "world/HouseGenerator.h"

namespace vln::train {
namespace fs = std::filesystem;

namespace {

// stream labels of data::deriveSeed, so that no two uses share draws
constexpr uint64_t kTrainViewStream = 1000;
constexpr uint64_t kEpochStream = 2000;
constexpr uint64_t kEvalViewStream = 3000;
// draws of a point before a house is declared to have no room on its main
// island (never happens with generated houses: rooms tile the floor)
constexpr int kMaxViewDraws = 100;
// held-out images per forward pass
constexpr int64_t kEvalChunk = 256;

}  // namespace

// ===========================================================================
// network, metrics
// ===========================================================================

double averagePrecision(std::span<const float> scores, std::span<const uint8_t> labels) {
  VLN_CHECK_ARG(scores.size() == labels.size(), "averagePrecision(): ", scores.size(),
                " scores but ", labels.size(), " labels");
  const int64_t positives = std::count_if(labels.begin(), labels.end(),
                                          [](uint8_t l) { return l != 0; });
  if (positives == 0) return std::numeric_limits<double>::quiet_NaN();
  std::vector<size_t> order(scores.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return scores[a] > scores[b]; });
  // walk down the thresholds; tied scores are one threshold
  double ap = 0.0;
  int64_t truePositives = 0, seen = 0;
  for (size_t i = 0; i < order.size();) {
    size_t j = i;
    int64_t groupPositives = 0;
    while (j < order.size() && scores[order[j]] == scores[order[i]]) {
      groupPositives += labels[order[j]] != 0 ? 1 : 0;
      ++j;
    }
    truePositives += groupPositives;
    seen += static_cast<int64_t>(j - i);
    ap += static_cast<double>(groupPositives) * static_cast<double>(truePositives) /
          static_cast<double>(seen);
    i = j;
  }
  return ap / static_cast<double>(positives);
}

MultiLabelMetrics multiLabelMetrics(std::span<const float> probabilities,
                                    std::span<const uint8_t> labels, int64_t numLabels) {
  VLN_CHECK_ARG(numLabels > 0 && probabilities.size() == labels.size() &&
                    labels.size() % static_cast<size_t>(numLabels) == 0,
                "multiLabelMetrics(): ", probabilities.size(), " probabilities and ",
                labels.size(), " labels do not form rows of ", numLabels);
  const size_t rows = labels.size() / static_cast<size_t>(numLabels);
  MultiLabelMetrics m;
  m.ap.assign(static_cast<size_t>(numLabels), std::numeric_limits<double>::quiet_NaN());
  int64_t tpAll = 0, fpAll = 0, fnAll = 0;
  double apSum = 0.0, f1Sum = 0.0;
  std::vector<float> column(rows);
  std::vector<uint8_t> truth(rows);
  for (int64_t l = 0; l < numLabels; ++l) {
    int64_t tp = 0, fp = 0, fn = 0;
    for (size_t r = 0; r < rows; ++r) {
      const size_t k = r * static_cast<size_t>(numLabels) + static_cast<size_t>(l);
      column[r] = probabilities[k];
      truth[r] = labels[k];
      const bool predicted = probabilities[k] >= 0.5f;
      const bool actual = labels[k] != 0;
      tp += predicted && actual;
      fp += predicted && !actual;
      fn += !predicted && actual;
    }
    tpAll += tp;
    fpAll += fp;
    fnAll += fn;
    if (tp + fn == 0) continue;  // no positive: AP and recall are undefined
    m.ap[static_cast<size_t>(l)] = averagePrecision(column, truth);
    apSum += m.ap[static_cast<size_t>(l)];
    f1Sum += 2.0 * static_cast<double>(tp) / static_cast<double>(2 * tp + fp + fn);
    ++m.labels_evaluated;
  }
  if (m.labels_evaluated > 0) {
    m.mean_ap = apSum / m.labels_evaluated;
    m.macro_f1 = f1Sum / m.labels_evaluated;
  }
  const int64_t denominator = 2 * tpAll + fpAll + fnAll;
  m.micro_f1 = denominator > 0 ? 2.0 * static_cast<double>(tpAll) / static_cast<double>(denominator)
                               : 0.0;
  return m;
}

namespace {

// ===========================================================================
// views
// ===========================================================================

struct View {
  int house = -1;
  sim::AgentState pose;
};

// A rendered set of views with their labels.
struct ViewSet {
  torch::Tensor rgb;         // [S, H, W, 3] uint8
  torch::Tensor categories;  // [S, C] float 0/1
  torch::Tensor colors;      // [S, K] float 0/1
  torch::Tensor room;        // [S] int64
  std::vector<uint8_t> categoryLabels;  // [S * C], for the metrics
  std::vector<uint8_t> colorLabels;     // [S * K]
  std::vector<int64_t> roomLabels;      // [S]
  int64_t size() const { return static_cast<int64_t>(roomLabels.size()); }
};

std::vector<View> sampleViews(const std::vector<std::shared_ptr<const sim::Scene>>& scenes,
                              int count, uint64_t seed) {
  std::vector<View> views(static_cast<size_t>(count));
  for (int k = 0; k < count; ++k) {
    std::mt19937_64 rng(common::deriveSeed(seed, static_cast<uint64_t>(k)));
    View& view = views[static_cast<size_t>(k)];
    view.house = common::uniformIndex(rng, static_cast<int>(scenes.size()));
    const sim::Scene& scene = *scenes[static_cast<size_t>(view.house)];
    bool found = false;
    for (int draw = 0; draw < kMaxViewDraws && !found; ++draw) {
      view.pose.position = scene.navmesh().randomPoint(rng, /*island=*/0);
      found = scene.semantics().roomAt(view.pose.position) >= 0;
    }
    VLN_CHECK_ARG(found, "rgb_semantic: scene '", scene.name(), "': ", kMaxViewDraws,
                  " navigable points in a row lie in no room");
    view.pose.heading = common::uniformRange(rng, -kPi, kPi);
  }
  return views;
}

// Label counts of the training views, for the prior predictor.
struct LabelCounts {
  std::vector<int64_t> categories, colors, rooms;
  int64_t images = 0;
};

}  // namespace

// ===========================================================================
// the pretrainer
// ===========================================================================

struct SemanticPretrainer::Impl : PretrainRun {
  models::SemanticNet net{nullptr};
  std::unique_ptr<torch::optim::Adam> optimizer;
  LabelCounts counts;
  NonFiniteLosses nonFinite;
  double lastEpochLoss = 0.0;

  int64_t numCategories() const {
    return static_cast<int64_t>(world::houseObjectCategories().size());
  }
  int64_t numColors() const {
    return static_cast<int64_t>(world::houseColorNames().size());
  }
  int64_t numRooms() const {
    return static_cast<int64_t>(world::houseRoomTypes().size());
  }

  // renders `views` of `scenes` with their labels; one simulator per house
  ViewSet render(const std::vector<View>& views,
                 const std::vector<std::shared_ptr<const sim::Scene>>& scenes,
                 const std::string& label) {
    const int64_t width = config.sim.rgb.width, height = config.sim.rgb.height;
    const int64_t count = static_cast<int64_t>(views.size());
    const int64_t c = numCategories(), k = numColors();
    ViewSet set;
    set.rgb = torch::empty({count, height, width, 3}, torch::kUInt8);
    set.categoryLabels.assign(static_cast<size_t>(count * c), 0);
    set.colorLabels.assign(static_cast<size_t>(count * k), 0);
    set.roomLabels.assign(static_cast<size_t>(count), 0);
    std::vector<std::vector<size_t>> byHouse(scenes.size());
    for (size_t i = 0; i < views.size(); ++i)
      byHouse[static_cast<size_t>(views[i].house)].push_back(i);
    uint8_t* pixels = set.rgb.data_ptr<uint8_t>();
    const size_t imageBytes = static_cast<size_t>(width * height * 3);
    common::ProgressLine line(label, count, "images");
    std::mutex lineMutex;
    // each house renders its views on one thread into disjoint rows
    pool->parallelFor(scenes.size(), [&](size_t h) {
      if (byHouse[h].empty()) return;
      sim::Simulator simulator(scenes[h], config.sim, config.task);
      sim::Observation obs;
      std::vector<int32_t> ids;
      for (size_t i : byHouse[h]) {
        simulator.reset(views[i].pose);
        simulator.observe(obs);
        simulator.observeSemantic(ids);
        std::copy(obs.rgb.begin(), obs.rgb.end(), pixels + i * imageBytes);
        const ViewLabels labels = labelView(scenes[h]->semantics(), ids, views[i].pose.position,
                                            config.pretrain.min_object_fraction);
        VLN_ASSERT(labels.room >= 0);  // sampleViews() only keeps points in rooms
        std::copy(labels.categories.begin(), labels.categories.end(),
                  set.categoryLabels.begin() + static_cast<int64_t>(i) * c);
        std::copy(labels.colors.begin(), labels.colors.end(),
                  set.colorLabels.begin() + static_cast<int64_t>(i) * k);
        set.roomLabels[i] = labels.room;
        std::lock_guard<std::mutex> lock(lineMutex);
        line.advance();
      }
    });
    set.categories = torch::from_blob(set.categoryLabels.data(), {count, c}, torch::kUInt8)
                         .to(torch::kFloat32);
    set.colors =
        torch::from_blob(set.colorLabels.data(), {count, k}, torch::kUInt8).to(torch::kFloat32);
    set.room = torch::from_blob(set.roomLabels.data(), {count}, torch::kLong).clone();
    return set;
  }

  void countLabels(const ViewSet& set) {
    const int64_t c = numCategories(), k = numColors();
    counts.categories.resize(static_cast<size_t>(c), 0);
    counts.colors.resize(static_cast<size_t>(k), 0);
    counts.rooms.resize(static_cast<size_t>(numRooms()), 0);
    for (int64_t i = 0; i < set.size(); ++i) {
      for (int64_t l = 0; l < c; ++l)
        counts.categories[static_cast<size_t>(l)] += set.categoryLabels[static_cast<size_t>(i * c + l)];
      for (int64_t l = 0; l < k; ++l)
        counts.colors[static_cast<size_t>(l)] += set.colorLabels[static_cast<size_t>(i * k + l)];
      ++counts.rooms[static_cast<size_t>(set.roomLabels[static_cast<size_t>(i)])];
    }
    counts.images += set.size();
  }

  // per image: the binary cross-entropies summed over the labels (each
  // label is a decision of its own; a mean over 29 labels would shrink the
  // rare ones' gradients next to the room's) plus the room cross-entropy;
  // then the mean over the batch
  torch::Tensor loss(const models::SemanticLogits& logits, const torch::Tensor& categories,
                     const torch::Tensor& colors, const torch::Tensor& room) const {
    const double images = static_cast<double>(room.size(0));
    return (torch::binary_cross_entropy_with_logits(logits.categories, categories, {}, {},
                                                    at::Reduction::Sum) +
            torch::binary_cross_entropy_with_logits(logits.colors, colors, {}, {},
                                                    at::Reduction::Sum)) /
               images +
           torch::nn::functional::cross_entropy(logits.room, room);
  }

  // one epoch over `set`; returns the mean loss of the applied updates
  double trainEpoch(const ViewSet& set, int epoch) {
    std::vector<int64_t> order =
        shuffledOrder(static_cast<size_t>(set.size()), kEpochStream + static_cast<uint64_t>(epoch));
    const int64_t batchSize = config.pretrain.batch_size;
    const int64_t batches = (set.size() + batchSize - 1) / batchSize;
    common::ProgressLine line("train epoch " + std::to_string(epoch), batches, "updates");
    common::Stopwatch clock;
    double sum = 0.0;
    int64_t applied = 0;
    net->train();
    for (int64_t first = 0; first < set.size(); first += batchSize) {
      const int64_t n = std::min(batchSize, set.size() - first);
      const torch::Tensor index =
          torch::from_blob(order.data() + first, {n}, torch::kLong).clone();
      const torch::Tensor images = set.rgb.index_select(0, index).to(device);
      const torch::Tensor value =
          loss(net->forward(images), set.categories.index_select(0, index).to(device),
               set.colors.index_select(0, index).to(device),
               set.room.index_select(0, index).to(device));
      const double v = value.item<double>();
      line.advance();
      if (std::isnan(initialLoss)) initialLoss = v;
      if (!std::isfinite(v)) {
        nonFinite.skip(config, "rgb_semantic", /*model=*/"", updates);
        continue;
      }
      nonFinite.inARow = 0;
      applyUpdate(*optimizer, *net, value, config.trainer.grad_clip);
      ++updates;
      ++applied;
      sum += v;
      if (updates % config.trainer.log_every_updates == 0)
        metrics->write("update", {{"update", updates}, {"epoch", epoch}, {"loss", v}},
                       {{"train/loss", v}}, updates);
    }
    const double mean = sum / static_cast<double>(std::max<int64_t>(1, applied));
    const double seconds = clock.seconds();
    spdlog::info("epoch {}: {} updates in {:.1f} s ({:.0f} images/s), mean loss {:.4f}", epoch,
                 applied, seconds, seconds > 0 ? static_cast<double>(set.size()) / seconds : 0.0,
                 mean);
    return mean;
  }

  SemanticMetrics evaluateNet(const ViewSet& set) {
    torch::NoGradGuard noGrad;
    net->eval();
    std::vector<torch::Tensor> cat, col, room;
    for (int64_t first = 0; first < set.size(); first += kEvalChunk) {
      const int64_t n = std::min(kEvalChunk, set.size() - first);
      const models::SemanticLogits logits = net->forward(set.rgb.narrow(0, first, n).to(device));
      cat.push_back(torch::sigmoid(logits.categories).to(torch::kCPU));
      col.push_back(torch::sigmoid(logits.colors).to(torch::kCPU));
      room.push_back(logits.room.argmax(-1).to(torch::kCPU));
    }
    net->train();
    const torch::Tensor catP = torch::cat(cat).contiguous();
    const torch::Tensor colP = torch::cat(col).contiguous();
    const torch::Tensor roomP = torch::cat(room).contiguous();
    SemanticMetrics m;
    m.images = set.size();
    m.room_accuracy =
        (roomP == set.room).to(torch::kFloat64).mean().item<double>();
    m.categories = multiLabelMetrics({catP.data_ptr<float>(), static_cast<size_t>(catP.numel())},
                                     set.categoryLabels, numCategories());
    m.colors = multiLabelMetrics({colP.data_ptr<float>(), static_cast<size_t>(colP.numel())},
                                 set.colorLabels, numColors());
    return m;
  }

  // the predictor that ignores the image: training label frequencies
  SemanticMetrics evaluatePrior(const ViewSet& set) const {
    const double images = static_cast<double>(std::max<int64_t>(1, counts.images));
    auto frequencies = [&](const std::vector<int64_t>& labelCounts) {
      std::vector<float> rows;
      rows.reserve(labelCounts.size() * static_cast<size_t>(set.size()));
      for (int64_t i = 0; i < set.size(); ++i)
        for (int64_t n : labelCounts) rows.push_back(static_cast<float>(n / images));
      return rows;
    };
    SemanticMetrics m;
    m.images = set.size();
    const int64_t majority =
        std::max_element(counts.rooms.begin(), counts.rooms.end()) - counts.rooms.begin();
    int64_t correct = 0;
    for (int64_t r : set.roomLabels) correct += r == majority;
    m.room_accuracy = static_cast<double>(correct) / static_cast<double>(std::max<int64_t>(1, set.size()));
    m.categories =
        multiLabelMetrics(frequencies(counts.categories), set.categoryLabels, numCategories());
    m.colors = multiLabelMetrics(frequencies(counts.colors), set.colorLabels, numColors());
    return m;
  }

  void logMetrics(const std::string& name, const SemanticMetrics& m, int epoch) {
    spdlog::info("held-out {} after epoch {}: room accuracy {:.3f}, categories mAP {:.3f} "
                 "(micro F1 {:.3f}), colours mAP {:.3f} (micro F1 {:.3f})",
                 name, epoch, m.room_accuracy, m.categories.mean_ap, m.categories.micro_f1,
                 m.colors.mean_ap, m.colors.micro_f1);
  }
};

namespace {

nlohmann::json semanticMetricsJson(const SemanticMetrics& m) {
  auto labels = [](const MultiLabelMetrics& l, const std::vector<std::string>& names) {
    nlohmann::json ap = nlohmann::json::object();
    for (size_t i = 0; i < names.size() && i < l.ap.size(); ++i)
      if (std::isfinite(l.ap[i])) ap[names[i]] = l.ap[i];
    return nlohmann::json{{"mean_ap", l.mean_ap},   {"labels_evaluated", l.labels_evaluated},
                          {"micro_f1", l.micro_f1}, {"macro_f1", l.macro_f1},
                          {"ap", ap}};
  };
  return {{"images", m.images},
          {"room_accuracy", m.room_accuracy},
          {"categories", labels(m.categories, world::houseObjectCategories())},
          {"colors", labels(m.colors, world::houseColorNames())}};
}

}  // namespace

SemanticPretrainer::SemanticPretrainer(const ExperimentConfig& config, fs::path runDir)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  s.start(config, std::move(runDir), "rgb_semantic", "SemanticPretrainer");

  s.net = models::SemanticNet(
      config.model, static_cast<int64_t>(world::houseObjectCategories().size()),
      static_cast<int64_t>(world::houseColorNames().size()),
      static_cast<int64_t>(world::houseRoomTypes().size()));
  if (!config.model.rgb_weights.empty()) {
    models::loadModule(s.net->rgb->cnnModule(), config.model.rgb_weights);
    spdlog::info("RGB CNN initialised from {}", config.model.rgb_weights);
  }
  s.net->to(s.device);
  s.optimizer = std::make_unique<torch::optim::Adam>(s.net->parameters(),
                                                     torch::optim::AdamOptions(config.pretrain.lr));
  spdlog::info("semantic network ({} RGB CNN, {}x{}): {} parameters",
               models::encoderName(config.model.rgb_encoder), config.model.rgb_width,
               config.model.rgb_height, parameterCount(*s.net));
  s.openMetrics();
}

SemanticPretrainer::~SemanticPretrainer() = default;

SemanticResult SemanticPretrainer::run() {
  Impl& s = *impl_;
  const ExperimentConfig& config = s.config;
  const PretrainConfig& p = config.pretrain;
  const uint64_t seed = static_cast<uint64_t>(config.trainer.seed);
  common::Stopwatch clock;

  const ViewSet heldout = s.render(
      sampleViews(s.houses.heldout, p.eval_samples, common::deriveSeed(seed, kEvalViewStream)),
      s.houses.heldout, "render held-out views");

  SemanticResult result;
  for (int epoch = 0; epoch < p.iterations; ++epoch) {
    // fresh views every epoch
    const ViewSet train = s.render(
        sampleViews(s.houses.train, p.samples,
                    common::deriveSeed(seed, kTrainViewStream + static_cast<uint64_t>(epoch))),
        s.houses.train, "render epoch " + std::to_string(epoch));
    s.countLabels(train);
    result.train_images += train.size();
    setAdamLearningRate(*s.optimizer, roundLearningRate(p.lr, p.lr_schedule,
                                                        epoch, p.iterations));
    s.lastEpochLoss = s.trainEpoch(train, epoch);

    result.model = s.evaluateNet(heldout);
    result.prior = s.evaluatePrior(heldout);
    s.logMetrics("network", result.model, epoch);
    s.logMetrics("prior", result.prior, epoch);
    s.metrics->write("epoch",
                     {{"epoch", epoch},
                      {"lr", adamLearningRate(*s.optimizer)},
                      {"loss", s.lastEpochLoss},
                      {"updates", s.updates},
                      {"train_images", result.train_images},
                      {"heldout", semanticMetricsJson(result.model)},
                      {"prior", semanticMetricsJson(result.prior)}},
                     {{"epoch/loss", s.lastEpochLoss},
                      {"eval/room_accuracy", result.model.room_accuracy},
                      {"eval/category_map", result.model.categories.mean_ap},
                      {"eval/color_map", result.model.colors.mean_ap}},
                     epoch);
  }
  result.initial_loss = s.initialLoss;
  result.final_loss = s.lastEpochLoss;

  s.net->to(torch::kCPU);
  result.encoder_file = encoderOutputPath(config, s.runDir, "rgb_encoder.pt");
  models::saveModule(s.net->rgb->cnnModule(), result.encoder_file);
  models::saveModule(*s.net, s.runDir / "semantic_net.pt");
  result.seconds = clock.seconds();
  spdlog::info("rgb_semantic done in {:.1f} s: held-out room accuracy {:.3f} (prior {:.3f}), "
               "categories mAP {:.3f} (prior {:.3f}), colours mAP {:.3f} (prior {:.3f}); RGB "
               "encoder saved to {}",
               result.seconds, result.model.room_accuracy, result.prior.room_accuracy,
               result.model.categories.mean_ap, result.prior.categories.mean_ap,
               result.model.colors.mean_ap, result.prior.colors.mean_ap,
               result.encoder_file.string());

  nlohmann::json summary = s.summary("rgb_semantic", result.seconds);
  summary.update({
      {"epochs", p.iterations},
      {"images_per_epoch", p.samples},
      {"train_images", result.train_images},
      {"min_object_fraction", p.min_object_fraction},
      {"initial_loss", result.initial_loss},
      {"final_loss", result.final_loss},
      {"nonfinite_updates", s.nonFinite.total},
      {"rgb_encoder", models::encoderName(config.model.rgb_encoder)},
      {"rgb_size", {config.model.rgb_width, config.model.rgb_height}},
      {"encoder_file", result.encoder_file.string()},
      {"heldout", {{"network", semanticMetricsJson(result.model)},
                   {"prior", semanticMetricsJson(result.prior)}}}});
  s.finish(summary, {{"final/room_accuracy", result.model.room_accuracy},
                     {"final/category_map", result.model.categories.mean_ap}});
  return result;
}

}  // namespace vln::train
