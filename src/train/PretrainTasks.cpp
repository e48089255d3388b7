#include "train/PretrainTasks.h"

#include <spdlog/spdlog.h>
#include <torch/torch.h>

#include <exception>
#include <numeric>
#include <random>

#include "common/Check.h"
#include "common/Json.h"
#include "common/Progress.h"
#include "common/Random.h"
#include "common/ThreadPool.h"
#include "models/Policy.h"
#include "train/PointNavPretrainer.h"
#include "train/PretrainCommon.h"
#include "train/SemanticPretrainer.h"
#include "train/TextPretrainer.h"
#include "train/WaypointPretrainer.h"
#include "world/HouseGenerator.h"

namespace vln::train {
namespace fs = std::filesystem;

PretrainHouses generatePretrainHouses(const ExperimentConfig& config,
                                      int threads) {
  const PretrainConfig& p = config.pretrain;
  const int total = p.train_houses + p.heldout_houses;
  std::vector<std::shared_ptr<const sim::Scene>> scenes(
      static_cast<size_t>(total));
  common::ProgressLine line("pretraining houses", total, "houses");
  std::mutex lineMutex;
  // every house is its own seed, so the thread that builds it does not
  // change it
  common::ThreadPool pool(threads);
  pool.parallelFor(static_cast<size_t>(total), [&](size_t i) {
    const uint64_t seed = static_cast<uint64_t>(p.house_seed) + i;
    try {
      world::House house = world::generateHouse(seed, p.house);
      scenes[i] = sim::Scene::fromMesh(house.name, std::move(house.mesh),
                                       std::move(house.semantics),
                                       config.sim.navmesh);
    } catch (const std::exception& e) {
      throw std::invalid_argument(strCat(
          "pretraining: house seed ", seed, " (pretrain.house_seed ",
          p.house_seed, " + ", i, ") cannot be built: ", e.what()));
    }
    VLN_CHECK_ARG(scenes[i]->navmesh().islandCount() > 0,
                  "pretraining: house seed ", seed, " has no navigable space");
    std::lock_guard<std::mutex> lock(lineMutex);
    line.advance();
  });
  PretrainHouses houses;
  houses.train.assign(scenes.begin(), scenes.begin() + p.train_houses);
  houses.heldout.assign(scenes.begin() + p.train_houses, scenes.end());
  return houses;
}

void validatePretrainConfig(const ExperimentConfig& config) {
  const PretrainConfig& p = config.pretrain;
  const std::string& task = config.trainer.task;
  VLN_CHECK_ARG(
      task == "depth_pointnav" || task == "rgb_semantic" ||
          task == "text_mlm" || task == "waypoint_predictor",
      "pretraining: trainer.task must be depth_pointnav, rgb_semantic, "
      "text_mlm or waypoint_predictor, got '",
      task, "'");
  if (task == "waypoint_predictor") {
    validateWaypointPretrainConfig(config);
    return;
  }
  if (task == "text_mlm") {
    validateTextPretrainConfig(config);
    return;
  }
  try {
    p.house.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(strCat("pretraining: pretrain.house: ",
                                       e.what()));
  }
  if (task == "depth_pointnav") {
    VLN_CHECK_ARG(!config.model.no_depth,
                  "pretraining: trainer.task depth_pointnav trains the depth "
                  "encoder, but model.no_depth is true");
    VLN_CHECK_ARG(p.min_goal_distance < p.max_goal_distance,
                  "pretraining: pretrain.min_goal_distance (",
                  p.min_goal_distance,
                  ") must be below pretrain.max_goal_distance (",
                  p.max_goal_distance, ")");
    // a goal inside the success radius at the start is no episode at all
    VLN_CHECK_ARG(p.min_goal_distance > p.success_distance,
                  "pretraining: pretrain.min_goal_distance (",
                  p.min_goal_distance,
                  ") must exceed pretrain.success_distance (",
                  p.success_distance, ")");
    VLN_CHECK_ARG(config.model.depth_width == config.sim.depth.camera.width &&
                      config.model.depth_height ==
                          config.sim.depth.camera.height,
                  "pretraining: model.depth_width x depth_height (",
                  config.model.depth_width, "x", config.model.depth_height,
                  ") must equal sim.depth.width x height (",
                  config.sim.depth.camera.width, "x",
                  config.sim.depth.camera.height, ")");
  } else {
    VLN_CHECK_ARG(!config.model.no_rgb,
                  "pretraining: trainer.task rgb_semantic trains the RGB "
                  "encoder, but model.no_rgb is true");
    VLN_CHECK_ARG(config.model.rgb_width == config.sim.rgb.width &&
                      config.model.rgb_height == config.sim.rgb.height,
                  "pretraining: model.rgb_width x rgb_height (",
                  config.model.rgb_width, "x", config.model.rgb_height,
                  ") must equal sim.rgb.width x height (",
                  config.sim.rgb.width, "x", config.sim.rgb.height, ")");
    VLN_CHECK_ARG(p.min_object_fraction > 0.0f,
                  "pretraining: pretrain.min_object_fraction must be "
                  "positive (a single stray pixel is no object in view), got ",
                  p.min_object_fraction);
  }
}

fs::path encoderOutputPath(const ExperimentConfig& config,
                           const fs::path& runDir,
                           const std::string& defaultName) {
  if (!config.pretrain.encoder_out.empty()) return config.pretrain.encoder_out;
  return runDir / defaultName;
}

// ===========================================================================
// PretrainCommon.h
// ===========================================================================

void PretrainRun::start(const ExperimentConfig& runConfig, fs::path dir,
                        const std::string& task, const std::string& className) {
  config = runConfig;
  runDir = std::move(dir);
  validatePretrainConfig(runConfig);
  VLN_CHECK_ARG(runConfig.trainer.task == task, className,
                ": trainer.task must be ", task, ", got '",
                runConfig.trainer.task, "'");
  device = models::modelDevice(runConfig.model);
  torch::set_num_threads(runConfig.trainer.torch_threads);
  torch::manual_seed(static_cast<uint64_t>(runConfig.trainer.seed));

  pool = std::make_unique<common::ThreadPool>(runConfig.trainer.env_threads);
  common::Stopwatch clock;
  houses = generatePretrainHouses(runConfig, runConfig.trainer.env_threads);
  const PretrainConfig& p = runConfig.pretrain;
  spdlog::info(
      "{}: {} training and {} held-out houses (seeds {}..{}) in {:.1f} s", task,
      houses.train.size(), houses.heldout.size(), p.house_seed,
      p.house_seed + p.train_houses + p.heldout_houses - 1, clock.seconds());
}

void PretrainRun::openMetrics() {
  metrics = std::make_unique<MetricsLog>(
      runDir / "metrics.jsonl",
      config.output.tensorboard ? runDir / "tb" : fs::path());
}

nlohmann::json PretrainRun::summary(const std::string& task,
                                    double seconds) const {
  const PretrainConfig& p = config.pretrain;
  return {{"task", task},
          {"seconds", seconds},
          {"train_houses", p.train_houses},
          {"heldout_houses", p.heldout_houses},
          {"house_seed", p.house_seed},
          {"updates", updates}};
}

void PretrainRun::finish(
    const nlohmann::json& record,
    const std::vector<std::pair<std::string, double>>& scalars) {
  common::writeJsonFile(runDir / "pretrain_metrics.json", record, 2);
  metrics->write("finished", record, scalars, updates);
}

std::vector<int64_t> PretrainRun::shuffledOrder(size_t count,
                                                uint64_t stream) const {
  std::vector<int64_t> order(count);
  std::iota(order.begin(), order.end(), int64_t{0});
  std::mt19937_64 rng(
      common::deriveSeed(static_cast<uint64_t>(config.trainer.seed), stream));
  common::deterministicShuffle(order, rng);
  return order;
}

void NonFiniteLosses::skip(const ExperimentConfig& config,
                           const std::string& task, const std::string& model,
                           int64_t update) {
  ++total;
  ++inARow;
  spdlog::warn("{}: non-finite loss at update {} skipped ({} in a row)",
               model.empty() ? task : model, update, inARow);
  VLN_CHECK_IO(inARow < config.trainer.max_nonfinite_updates, task, ": ",
               inARow, " non-finite losses in a row",
               model.empty() ? std::string() : " for the " + model,
               " (trainer.max_nonfinite_updates = ",
               config.trainer.max_nonfinite_updates, "); lower pretrain.lr");
}

void applyUpdate(torch::optim::Optimizer& optimizer, torch::nn::Module& module,
                 const torch::Tensor& loss, double gradClip) {
  optimizer.zero_grad();
  loss.backward();
  if (gradClip > 0.0)
    torch::nn::utils::clip_grad_norm_(module.parameters(), gradClip);
  optimizer.step();
}

int64_t parameterCount(const torch::nn::Module& module) {
  int64_t count = 0;
  for (const auto& p : module.parameters()) count += p.numel();
  return count;
}

// ===========================================================================
// the tasks
// ===========================================================================

void runDepthPointNavPretraining(const ExperimentConfig& config,
                                 const fs::path& runDir) {
  PointNavPretrainer pretrainer(config, runDir);
  pretrainer.run();
}

void runRgbSemanticPretraining(const ExperimentConfig& config,
                               const fs::path& runDir) {
  SemanticPretrainer pretrainer(config, runDir);
  pretrainer.run();
}

}  // namespace vln::train
