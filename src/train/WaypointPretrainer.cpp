#include "train/WaypointPretrainer.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <set>
#include <string>

#include "common/Check.h"
#include "common/Json.h"
#include "common/Progress.h"
#include "common/Random.h"
#include "common/ThreadPool.h"
#include "data/Episode.h"
#include "data/NavGraph.h"
#include "data/NodeTransfer.h"
#include "models/ObservationEncoder.h"
#include "models/Policy.h"
#include "models/StateDict.h"
#include "models/WaypointPredictor.h"
#include "sim/Panorama.h"
#include "sim/Scene.h"
#include "train/MetricsLog.h"
#include "train/PretrainCommon.h"
#include "waypoint/DepthWaypointBaseline.h"

namespace vln::train {
namespace fs = std::filesystem;

static_assert(models::kWaypointHeadings == waypoint::kNumHeadings &&
                  models::kWaypointDistances == waypoint::kNumDistances,
              "the predictor's output is the waypoint heatmap");

namespace {

constexpr const char* kTask = "waypoint_predictor";
// seed stream of the training headings (trainer.seed)
constexpr uint64_t kHeadingStream = 0x57504844;  // "WPHD"
constexpr uint64_t kOrderStream = 0x5750524f;    // "WPRO"

// One rendered panorama and what it is scored against.
struct RawSample {
  std::vector<float> depth;  // [V, H, W]
  std::vector<uint8_t> rgb;  // [V, H, W, 3]
  waypoint::NodeTargets targets;
  waypoint::NodeScore baseline;  // eval only
};

// What one house contributes before encoding.
struct HouseSamples {
  std::string name;
  int nodes = 0;
  int transferred = 0;
  std::vector<RawSample> samples;
};

// The encoded panoramas of one split.
struct SplitData {
  std::vector<torch::Tensor> depthChunks, rgbChunks, targetChunks;
  torch::Tensor depth, rgb, targets;  // [N, V, F], [N, V, F], [N, 120, 12]
  std::vector<waypoint::NodeTargets> nodes;
  waypoint::PredictorMetrics baseline, floor;  // evaluation splits only
  bool evaluation = false;
  int houses = 0, graphNodes = 0, transferred = 0;

  int64_t size() const { return static_cast<int64_t>(nodes.size()); }
};

// the split's scene ids, sorted (the waypoint-metrics command's order)
std::vector<std::string> splitScenes(const ExperimentConfig& config,
                                     const std::string& split) {
  const fs::path file =
      fs::path(config.dataset.data_path) / split / (split + ".json.gz");
  const data::EpisodeDataset episodes = data::readEpisodes(file);
  std::set<std::string> ids;
  for (const data::Episode& e : episodes.episodes) ids.insert(e.scene_id);
  VLN_CHECK_ARG(!ids.empty(), kTask, ": ", file.string(), " has no episodes");
  return {ids.begin(), ids.end()};
}

}  // namespace

void checkWaypointPanorama(const ExperimentConfig& config,
                           std::string_view task) {
  const models::ModelConfig& m = config.model;
  sim::checkPanoramaConfig(config.panorama, "panorama");
  VLN_CHECK_ARG(waypoint::kNumHeadings % config.panorama.num_views == 0, task,
                ": panorama.num_views (", config.panorama.num_views,
                ") must divide the ", waypoint::kNumHeadings, " heading bins");
  VLN_CHECK_ARG(m.usesDepth() || m.usesRgb(), task,
                ": model.no_depth and model.no_rgb leave no features");
  if (m.usesDepth()) {
    VLN_CHECK_ARG(m.depth_width == config.panorama.depth.camera.width &&
                      m.depth_height == config.panorama.depth.camera.height,
                  task, ": model.depth_width x depth_height (", m.depth_width,
                  "x", m.depth_height,
                  ") must equal panorama.depth.width x "
                  "height (",
                  config.panorama.depth.camera.width, "x",
                  config.panorama.depth.camera.height, ")");
    VLN_CHECK_ARG(!m.depth_trainable, task,
                  ": model.depth_trainable must be false (the encoders' "
                  "features are computed once and cached)");
  }
  if (m.usesRgb()) {
    VLN_CHECK_ARG(m.rgb_width == config.panorama.rgb.width &&
                      m.rgb_height == config.panorama.rgb.height,
                  task, ": model.rgb_width x rgb_height (", m.rgb_width, "x",
                  m.rgb_height, ") must equal panorama.rgb.width x height (",
                  config.panorama.rgb.width, "x", config.panorama.rgb.height,
                  ")");
    VLN_CHECK_ARG(!m.rgb_trainable, task,
                  ": model.rgb_trainable must be false (the encoders' "
                  "features are computed once and cached)");
  }
}

void validateWaypointPretrainConfig(const ExperimentConfig& config) {
  checkWaypointPanorama(config, kTask);
  config.waypoint.predictor.validate("waypoint.predictor");
  models::checkPredictorInputs(config.model, config.waypoint.predictor, kTask);
}

waypoint::PredictorMetrics scoreWaypointLogits(
    const torch::Tensor& logits,
    const std::vector<waypoint::NodeTargets>& targets,
    const WaypointPretrainConfig& config) {
  VLN_CHECK_ARG(logits.dim() == 3 &&
                    logits.size(0) == static_cast<int64_t>(targets.size()),
                "scoreWaypointLogits(): ", logits.size(0), " heatmaps for ",
                targets.size(), " targets");
  const torch::Tensor p =
      models::waypointProbabilities(logits.detach().to(torch::kCPU))
          .contiguous();
  waypoint::PredictorMetrics metrics;
  for (size_t i = 0; i < targets.size(); ++i) {
    const float* row = p[static_cast<int64_t>(i)].data_ptr<float>();
    const auto candidates = waypoint::heatmapNms(
        std::span<const float>(row, waypoint::kHeatmapSize),
        config.nms_max_candidates, config.nms_heading_radius,
        config.nms_distance_radius, static_cast<float>(config.nms_min_score));
    metrics.add(waypoint::scoreCandidates(candidates, targets[i]));
  }
  return metrics;
}

// ===========================================================================
// the run
// ===========================================================================

struct WaypointPretrainer::Impl {
  ExperimentConfig config;
  fs::path runDir;
  std::unique_ptr<MetricsLog> metrics;
  models::DepthEncoder depthEncoder{nullptr};
  models::RgbEncoder rgbEncoder{nullptr};
  models::WaypointPredictor net{nullptr};
  int64_t updates = 0;
  // whether the predictor reads RGB (the views are kept and encoded only
  // then)
  bool readsRgb() const {
    return models::predictorReadsRgb(config.model, config.waypoint.predictor);
  }

  // renders the panoramas of house `sceneId` (training: headings_per_node
  // random headings per node; evaluation: one, as the metrics command)
  HouseSamples renderHouse(const std::string& sceneId, bool training) const {
    const WaypointPretrainConfig& w = config.waypoint;
    HouseSamples house;
    const auto scene =
        sim::Scene::load(fs::path(config.sim.scenes_dir) / sceneId, config.sim);
    house.name = scene->name();
    const data::NavGraph graph =
        data::readNavGraph(fs::path(config.dataset.data_path) / "connectivity" /
                           (house.name + "_connectivity.json"));
    const auto transferred =
        data::transferGraph(graph, scene->navmesh(), data::TransferConfig{});
    std::vector<int> valid;
    for (int i = 0; i < graph.numNodes(); ++i)
      if (transferred[static_cast<size_t>(i)].valid) valid.push_back(i);
    house.nodes = graph.numNodes();
    house.transferred = static_cast<int>(valid.size());
    // evenly spaced when capped, as the metrics command picks them
    std::vector<int> nodes = valid;
    if (w.max_nodes_per_house >= 0 &&
        static_cast<int>(valid.size()) > w.max_nodes_per_house) {
      nodes.clear();
      for (int k = 0; k < w.max_nodes_per_house; ++k)
        nodes.push_back(valid[static_cast<size_t>(k) * valid.size() /
                              static_cast<size_t>(w.max_nodes_per_house)]);
    }
    sim::PanoramaConfig panoramaConfig = config.panorama;
    panoramaConfig.threads = 1;  // houses render in parallel instead
    sim::PanoramaRenderer renderer(*scene, panoramaConfig, config.sim.renderer);
    sim::Panorama panorama;
    const int headings = training ? w.headings_per_node : 1;
    for (int node : nodes) {
      const std::string& id = graph.node(node).id;
      for (int h = 0; h < headings; ++h) {
        std::mt19937_64 rng =
            training ? std::mt19937_64(common::episodeSeed(
                           common::deriveSeed(
                               static_cast<uint64_t>(config.trainer.seed),
                               kHeadingStream),
                           house.name + "/" + id + "/" + std::to_string(h)))
                     : std::mt19937_64(common::episodeSeed(
                           static_cast<uint64_t>(w.eval_seed), id));
        const float heading = common::uniformRange(rng, -kPi, kPi);
        RawSample sample;
        sample.targets = waypoint::nodeTargets(graph, transferred, node,
                                               heading, scene->navmesh(),
                                               config.sim.agent, w.targets);
        if (!sample.targets.kept) continue;
        renderer.render(sample.targets.agent, panorama);
        if (!training)
          sample.baseline = waypoint::scoreCandidates(
              waypoint::depthBaselineCandidates(panorama, panoramaConfig,
                                                waypoint::DepthBaselineConfig{})
                  .candidates,
              sample.targets);
        if (config.model.usesDepth()) sample.depth = panorama.depth;
        if (readsRgb()) sample.rgb = panorama.rgb;
        house.samples.push_back(std::move(sample));
      }
    }
    return house;
  }

  // encodes one house's panoramas into `split` and frees them
  void encode(HouseSamples& house, SplitData& split) {
    torch::NoGradGuard noGrad;
    const sim::PanoramaConfig& pc = config.panorama;
    const int64_t n = static_cast<int64_t>(house.samples.size());
    const int64_t v = pc.num_views;
    ++split.houses;
    split.graphNodes += house.nodes;
    split.transferred += house.transferred;
    if (n == 0) return;
    torch::Tensor targets =
        torch::empty({n, waypoint::kNumHeadings, waypoint::kNumDistances});
    for (int64_t i = 0; i < n; ++i) {
      RawSample& s = house.samples[static_cast<size_t>(i)];
      std::memcpy(targets[i].data_ptr<float>(), s.targets.heatmap.data(),
                  sizeof(float) * waypoint::kHeatmapSize);
      if (!split.evaluation) continue;
      split.baseline.add(s.baseline);
      std::vector<waypoint::Candidate> own;
      for (const auto& t : s.targets.targets)
        own.push_back(waypoint::candidateAt(t.heading_bin, t.distance_bin, 1));
      split.floor.add(waypoint::scoreCandidates(own, s.targets));
    }
    split.targetChunks.push_back(targets);
    if (depthEncoder) {
      const int64_t hgt = pc.depth.camera.height, wid = pc.depth.camera.width;
      torch::Tensor images = torch::empty({n * v, hgt, wid, 1});
      for (int64_t i = 0; i < n; ++i)
        std::memcpy(images[i * v].data_ptr<float>(),
                    house.samples[static_cast<size_t>(i)].depth.data(),
                    sizeof(float) * v * hgt * wid);
      split.depthChunks.push_back(
          depthEncoder->forward(images).reshape({n, v, -1}));
    }
    if (rgbEncoder) {
      const int64_t hgt = pc.rgb.height, wid = pc.rgb.width;
      torch::Tensor images = torch::empty({n * v, hgt, wid, 3}, torch::kUInt8);
      for (int64_t i = 0; i < n; ++i)
        std::memcpy(images[i * v].data_ptr<uint8_t>(),
                    house.samples[static_cast<size_t>(i)].rgb.data(),
                    static_cast<size_t>(v * hgt * wid * 3));
      split.rgbChunks.push_back(
          rgbEncoder->forward(images).reshape({n, v, -1}));
    }
    for (RawSample& s : house.samples)
      split.nodes.push_back(std::move(s.targets));
    house.samples.clear();
  }

  SplitData collect(const std::string& splitName, bool training) {
    const std::vector<std::string> scenes = splitScenes(config, splitName);
    SplitData split;
    split.evaluation = !training;
    const size_t group = static_cast<size_t>(config.trainer.env_threads);
    common::ThreadPool pool(config.trainer.env_threads);
    common::ProgressLine line(std::string(kTask) + " " + splitName,
                              static_cast<int64_t>(scenes.size()), "houses");
    // a group of houses renders in parallel, then encodes in house order:
    // memory holds one group's raw panoramas
    for (size_t start = 0; start < scenes.size(); start += group) {
      const size_t count = std::min(group, scenes.size() - start);
      std::vector<HouseSamples> houses(count);
      pool.parallelFor(count, [&](size_t i) {
        houses[i] = renderHouse(scenes[start + i], training);
      });
      for (HouseSamples& house : houses) {
        encode(house, split);
        line.advance();
      }
    }
    VLN_CHECK_ARG(split.size() > 0, kTask, ": split ", splitName,
                  " has no node with targets in open space");
    split.targets = torch::cat(split.targetChunks);
    if (!split.depthChunks.empty()) split.depth = torch::cat(split.depthChunks);
    if (!split.rgbChunks.empty()) split.rgb = torch::cat(split.rgbChunks);
    split.targetChunks.clear();
    split.depthChunks.clear();
    split.rgbChunks.clear();
    spdlog::info(
        "{}: {} houses, {} nav-graph nodes, {} transferred, {} panoramas with "
        "targets ({})",
        splitName, split.houses, split.graphNodes, split.transferred,
        split.size(), training ? "training" : "evaluation");
    return split;
  }

  static torch::Tensor rows(const torch::Tensor& t, const torch::Tensor& idx) {
    return t.defined() ? t.index_select(0, idx) : torch::Tensor();
  }

  models::WaypointLoss lossKind() const {
    return config.waypoint.loss == "softmax" ? models::WaypointLoss::kSoftmax
                                             : models::WaypointLoss::kMse;
  }

  // logits of every panorama of `split` in evaluation mode, and the loss
  std::pair<torch::Tensor, double> predict(const SplitData& split) {
    torch::NoGradGuard noGrad;
    net->eval();
    std::vector<torch::Tensor> chunks;
    double lossSum = 0.0;
    const int64_t batch = config.waypoint.batch_size;
    for (int64_t start = 0; start < split.size(); start += batch) {
      const torch::Tensor idx =
          torch::arange(start, std::min(split.size(), start + batch));
      const torch::Tensor logits =
          net->forward(rows(split.depth, idx), rows(split.rgb, idx));
      lossSum += models::waypointLoss(logits, rows(split.targets, idx),
                                      lossKind(), config.waypoint.target_scale)
                     .item<double>() *
                 static_cast<double>(idx.size(0));
      chunks.push_back(logits);
    }
    net->train();
    return {torch::cat(chunks), lossSum / static_cast<double>(split.size())};
  }

  WaypointPretrainResult run() {
    const WaypointPretrainConfig& w = config.waypoint;
    common::Stopwatch clock;
    torch::set_num_threads(config.trainer.torch_threads);
    torch::manual_seed(static_cast<uint64_t>(config.trainer.seed));
    fs::create_directories(runDir);
    metrics = std::make_unique<MetricsLog>(
        runDir / "metrics.jsonl",
        config.output.tensorboard ? runDir / "tb" : fs::path());

    // frozen encoders with their pretrained weights, in evaluation mode
    if (config.model.usesDepth()) {
      depthEncoder = models::DepthEncoder(config.model);
      if (!config.model.depth_weights.empty())
        models::loadModule(depthEncoder->cnnModule(),
                           config.model.depth_weights);
      depthEncoder->eval();
    }
    if (readsRgb()) {
      rgbEncoder = models::RgbEncoder(config.model);
      if (!config.model.rgb_weights.empty())
        models::loadModule(rgbEncoder->cnnModule(), config.model.rgb_weights);
      rgbEncoder->eval();
    }
    const SplitData train = collect(w.train_split, true);
    const SplitData eval = collect(w.eval_split, false);
    const double renderSeconds = clock.seconds();

    net = models::makeWaypointPredictor(config.model, w.predictor,
                                        config.panorama.num_views);
    torch::optim::AdamW optimizer(
        net->parameters(),
        torch::optim::AdamWOptions(w.lr).weight_decay(w.weight_decay));
    spdlog::info(
        "{}: {} parameters; {} training and {} evaluation panoramas "
        "rendered and encoded in {:.1f} s",
        kTask, parameterCount(*net), train.size(), eval.size(), renderSeconds);

    WaypointPretrainResult result;
    result.train_panoramas = train.size();
    result.eval_panoramas = eval.size();
    result.baseline = eval.baseline;
    result.floor = eval.floor;
    NonFiniteLosses nonFinite;
    nlohmann::json history = nlohmann::json::array();
    bool first = true;
    for (int epoch = 0; epoch < w.epochs; ++epoch) {
      net->train();
      std::vector<int64_t> order(static_cast<size_t>(train.size()));
      std::iota(order.begin(), order.end(), int64_t{0});
      std::mt19937_64 rng(common::deriveSeed(
          common::deriveSeed(static_cast<uint64_t>(config.trainer.seed),
                             kOrderStream),
          static_cast<uint64_t>(epoch)));
      common::deterministicShuffle(order, rng);
      const torch::Tensor all = torch::tensor(order, torch::kInt64);
      double lossSum = 0.0;
      int64_t batches = 0;
      for (int64_t start = 0; start < train.size(); start += w.batch_size) {
        const torch::Tensor idx =
            all.slice(0, start, std::min(train.size(), start + w.batch_size));
        const torch::Tensor logits =
            net->forward(rows(train.depth, idx), rows(train.rgb, idx));
        const torch::Tensor loss = models::waypointLoss(
            logits, rows(train.targets, idx), lossKind(), w.target_scale);
        const double value = loss.item<double>();
        if (first) {
          result.initial_loss = value;
          first = false;
        }
        if (!std::isfinite(value)) {
          nonFinite.skip(config, kTask, "", updates);
          continue;
        }
        nonFinite.inARow = 0;
        applyUpdate(optimizer, *net, loss, config.trainer.grad_clip);
        ++updates;
        lossSum += value;
        ++batches;
        if (updates % config.trainer.log_every_updates == 0)
          metrics->write("train", {{"epoch", epoch}, {"loss", value}},
                         {{"train/loss", value}}, updates);
      }
      result.final_loss = batches > 0
                              ? lossSum / static_cast<double>(batches)
                              : std::numeric_limits<double>::quiet_NaN();
      const auto [logits, evalLoss] = predict(eval);
      result.model = scoreWaypointLogits(logits, eval.nodes, w);
      const nlohmann::json record = {{"epoch", epoch},
                                     {"train_loss", result.final_loss},
                                     {"eval_loss", evalLoss},
                                     {"model", result.model.toJson()}};
      history.push_back(record);
      metrics->write("eval", record,
                     {{"eval/loss", evalLoss},
                      {"eval/d_C", result.model.meanChamfer()},
                      {"eval/d_H", result.model.meanHausdorff()},
                      {"eval/open", result.model.openShare()},
                      {"eval/candidates", result.model.candidatesPerNode()}},
                     updates);
      spdlog::info(
          "{}: epoch {}/{} train loss {:.4f}, {} loss {:.4f}: {:.2f} "
          "candidates, %Open {:.1f}, d_C {:.3f} m, d_H {:.3f} m",
          kTask, epoch + 1, w.epochs, result.final_loss, w.eval_split, evalLoss,
          result.model.candidatesPerNode(), 100.0 * result.model.openShare(),
          result.model.meanChamfer(), result.model.meanHausdorff());
    }

    result.weights_file = w.weights_out.empty()
                              ? runDir / "waypoint_predictor.pt"
                              : fs::path(w.weights_out);
    if (result.weights_file.has_parent_path())
      fs::create_directories(result.weights_file.parent_path());
    models::saveModule(*net, result.weights_file);
    result.seconds = clock.seconds();
    const nlohmann::json record = {{"task", kTask},
                                   {"seconds", result.seconds},
                                   {"render_encode_seconds", renderSeconds},
                                   {"updates", updates},
                                   {"nonfinite_updates", nonFinite.total},
                                   {"parameters", parameterCount(*net)},
                                   {"train_split", w.train_split},
                                   {"eval_split", w.eval_split},
                                   {"train_houses", train.houses},
                                   {"train_panoramas", train.size()},
                                   {"eval_houses", eval.houses},
                                   {"eval_nodes", eval.graphNodes},
                                   {"eval_transferred", eval.transferred},
                                   {"eval_panoramas", eval.size()},
                                   {"initial_loss", result.initial_loss},
                                   {"final_loss", result.final_loss},
                                   {"model", result.model.toJson()},
                                   {"baseline", result.baseline.toJson()},
                                   {"targets", result.floor.toJson()},
                                   {"epochs", history},
                                   {"weights", result.weights_file.string()}};
    common::writeJsonFile(runDir / "pretrain_metrics.json", record, 2);
    metrics->write("finished", record,
                   {{"final/d_C", result.model.meanChamfer()},
                    {"final/d_H", result.model.meanHausdorff()}},
                   updates);
    spdlog::info("{}: wrote {} and {} in {:.1f} s", kTask,
                 result.weights_file.string(),
                 (runDir / "pretrain_metrics.json").string(), result.seconds);
    return result;
  }
};

WaypointPretrainer::WaypointPretrainer(const ExperimentConfig& config,
                                       fs::path runDir)
    : impl_(std::make_unique<Impl>()) {
  VLN_CHECK_ARG(config.trainer.task == kTask,
                "WaypointPretrainer: trainer.task must be ", kTask, ", got '",
                config.trainer.task, "'");
  validateWaypointPretrainConfig(config);
  impl_->config = config;
  impl_->runDir = std::move(runDir);
}

WaypointPretrainer::~WaypointPretrainer() = default;

WaypointPretrainResult WaypointPretrainer::run() { return impl_->run(); }

void runWaypointPredictorPretraining(const ExperimentConfig& config,
                                     const fs::path& runDir) {
  WaypointPretrainer pretrainer(config, runDir);
  pretrainer.run();
}

}  // namespace vln::train
