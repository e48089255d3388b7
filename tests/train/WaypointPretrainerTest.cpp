// Tests src/train/WaypointPretrainer.cpp: the config checks, the scoring
// path (softmax, NMS, PredictorMetrics) on a hand-made heatmap, the shipped
// config, and a tiny run end to end on the shared tiny world (panoramas at
// the nav-graph nodes, training, evaluation, weights and metrics files).

#include "train/WaypointPretrainer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "common/Json.h"
#include "models/StateDict.h"
#include "models/WaypointPredictor.h"
#include "support/TestPaths.h"
#include "train/TrainTestWorld.h"

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// a tiny waypoint run on the tiny world: 32x32 small CNNs, random encoders
ExperimentConfig tinyConfig(const test::TinyWorld& world,
                            const fs::path& runDir) {
  ExperimentConfig c;
  c.trainer.task = "waypoint_predictor";
  c.trainer.torch_threads = 1;
  c.trainer.env_threads = 2;
  c.trainer.log_every_updates = 1;
  c.dataset.data_path = world.data.string();
  c.sim.scenes_dir = world.scenes.string();
  for (auto* camera : {&c.sim.rgb, &c.sim.depth.camera, &c.panorama.rgb,
                       &c.panorama.depth.camera}) {
    camera->width = 32;
    camera->height = 32;
  }
  c.model.rgb_encoder = models::EncoderType::kSmallCnn;
  c.model.depth_encoder = models::EncoderType::kSmallCnn;
  c.model.rgb_width = c.model.rgb_height = 32;
  c.model.depth_width = c.model.depth_height = 32;
  c.waypoint.headings_per_node = 2;
  c.waypoint.max_nodes_per_house = 6;
  c.waypoint.epochs = 3;
  c.waypoint.batch_size = 4;
  c.waypoint.predictor.hidden_size = 32;
  c.waypoint.predictor.ff_size = 32;
  c.output.dir = runDir.string();
  c.output.tensorboard = false;
  return c;
}

void expectRejected(const ExperimentConfig& config, const std::string& what) {
  try {
    validateWaypointPretrainConfig(config);
    ADD_FAILURE() << "expected an error mentioning " << what;
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr(what));
  }
}

TEST(WaypointPretrainerTest, ConfigChecksNameTheKey) {
  const ExperimentConfig good = tinyConfig(test::TinyWorld{}, "unused");
  EXPECT_NO_THROW(validateWaypointPretrainConfig(good));
  ExperimentConfig c = good;
  c.panorama.depth.camera.width = 64;
  expectRejected(c, "panorama.depth.width");
  c = good;
  c.panorama.rgb.height = 16;
  expectRejected(c, "panorama.rgb.width x height");
  c = good;
  c.model.depth_trainable = true;
  expectRejected(c, "model.depth_trainable");
  c = good;
  c.panorama.num_views = 7;
  expectRejected(c, "panorama.num_views (7)");
  c = good;
  c.waypoint.predictor.heads = 5;
  expectRejected(c, "waypoint.predictor.hidden_size");
  c = good;
  c.model.no_rgb = c.model.no_depth = true;
  expectRejected(c, "no_rgb");
  // the policy could read RGB, the predictor nothing
  c = good;
  c.model.no_depth = true;
  c.waypoint.predictor.rgb = false;
  expectRejected(c, "waypoint.predictor.rgb is false");
}

TEST(WaypointPretrainerTest, ShippedConfigLoadsAndValidates) {
  const ExperimentConfig config = loadExperimentConfig(
      vln::test::sourcePath() / "configs" / "waypoint" / "predictor.yaml");
  EXPECT_EQ(config.trainer.task, "waypoint_predictor");
  EXPECT_EQ(config.panorama.depth.camera.width, config.model.depth_width);
  EXPECT_NO_THROW(validateWaypointPretrainConfig(config));
}

TEST(WaypointPretrainerTest, ScoresTheSoftmaxPeaksAfterNms) {
  // one target 1 m straight ahead-left (bin 30 = 90 degrees, distance bin
  // 3 = 1 m), everything open
  waypoint::NodeTargets node;
  node.agent.position = Vec3f(1.0f, 0.0f, 2.0f);
  node.agent.heading = 0.3f;
  node.open.fill(3.0f);
  waypoint::TargetWaypoint t;
  t.heading_bin = 30;
  t.distance_bin = 3;
  t.position = waypoint::fromPolar(node.agent, waypoint::binHeading(30),
                                   waypoint::binDistance(3));
  node.targets.push_back(t);
  node.kept = true;

  torch::Tensor logits = torch::zeros({2, 120, 12});
  logits[0][30][3] = 20.0f;  // on the target
  logits[1][90][3] = 20.0f;  // opposite: 2 m away
  WaypointPretrainConfig config;
  config.nms_min_score = 0.01;  // only the peaks survive
  const waypoint::PredictorMetrics m =
      scoreWaypointLogits(logits, {node, node}, config);
  EXPECT_EQ(m.nodes, 2);
  EXPECT_EQ(m.candidates, 2);
  EXPECT_NEAR(m.chamfer_sum, 0.0 + 2.0, 1e-4);
  EXPECT_NEAR(m.meanHausdorff(), 1.0, 1e-4);
  // without a threshold NMS keeps picking the (tiny) rest of the map, as
  // Hong et al.'s, up to 5 a node (fewer when a pick repeats a heading)
  config.nms_min_score = 0.0;
  const int64_t all =
      scoreWaypointLogits(logits, {node, node}, config).candidates;
  EXPECT_GT(all, 2);
  EXPECT_LE(all, 10);
  EXPECT_THROW(scoreWaypointLogits(logits, {node}, config),
               std::invalid_argument);
}

TEST(WaypointPretrainerTest, TinyRunTrainsEvaluatesAndWritesWeights) {
  const test::TinyWorld& world = test::tinyWorld();
  vln::test::TempDir dir;
  const ExperimentConfig config = tinyConfig(world, dir / "run");
  WaypointPretrainer pretrainer(config, dir / "run");
  const WaypointPretrainResult result = pretrainer.run();

  EXPECT_GT(result.train_panoramas, 0);
  EXPECT_GT(result.eval_panoramas, 0);
  EXPECT_TRUE(std::isfinite(result.initial_loss));
  // a few epochs of the squared error from a fresh head lower it
  EXPECT_LT(result.final_loss, result.initial_loss);
  EXPECT_EQ(result.model.nodes, result.eval_panoramas);
  EXPECT_EQ(result.baseline.nodes, result.eval_panoramas);
  EXPECT_EQ(result.floor.nodes, result.eval_panoramas);
  EXPECT_LE(result.model.candidatesPerNode(), 5.0);
  EXPECT_GT(result.model.candidatesPerNode(), 0.0);
  EXPECT_LT(result.floor.meanChamfer(), 0.2);  // the quantisation floor

  // the weights load strictly into the same network
  ASSERT_EQ(result.weights_file, dir / "run" / "waypoint_predictor.pt");
  models::WaypointPredictor net = models::makeWaypointPredictor(
      config.model, config.waypoint.predictor, 12);
  EXPECT_NO_THROW(models::loadModule(*net, result.weights_file));

  const nlohmann::json metrics =
      common::readJsonFile(dir / "run" / "pretrain_metrics.json");
  EXPECT_EQ(metrics["task"], "waypoint_predictor");
  EXPECT_EQ(metrics["epochs"].size(), 3u);
  EXPECT_EQ(metrics["eval_panoramas"], result.eval_panoramas);
  EXPECT_EQ(metrics["model"]["nodes"], result.eval_panoramas);
  EXPECT_TRUE(metrics.contains("baseline"));
  EXPECT_TRUE(metrics.contains("targets"));
  std::ifstream log(dir / "run" / "metrics.jsonl");
  int evals = 0;
  for (std::string line; std::getline(log, line);)
    evals += nlohmann::json::parse(line)["type"] == "eval";
  EXPECT_EQ(evals, 3);

  // the same seed renders and trains the same run
  WaypointPretrainer again(config, dir / "again");
  const WaypointPretrainResult second = again.run();
  EXPECT_EQ(second.train_panoramas, result.train_panoramas);
  EXPECT_DOUBLE_EQ(second.final_loss, result.final_loss);
  EXPECT_DOUBLE_EQ(second.model.chamfer_sum, result.model.chamfer_sum);
}

// waypoint.predictor.rgb false: a depth-only predictor beside a model that
// has RGB; its weights load into that predictor and not into one reading RGB
TEST(WaypointPretrainerTest, DepthOnlyPredictorBesideAnRgbModel) {
  const test::TinyWorld& world = test::tinyWorld();
  vln::test::TempDir dir;
  ExperimentConfig config = tinyConfig(world, dir / "run");
  ASSERT_TRUE(config.model.usesRgb());
  config.waypoint.predictor.rgb = false;
  EXPECT_FALSE(
      models::predictorReadsRgb(config.model, config.waypoint.predictor));
  const WaypointPretrainResult result =
      WaypointPretrainer(config, dir / "run").run();
  EXPECT_GT(result.eval_panoramas, 0);
  EXPECT_LT(result.final_loss, result.initial_loss);

  models::WaypointPredictor depthOnly = models::makeWaypointPredictor(
      config.model, config.waypoint.predictor, 12);
  EXPECT_FALSE(depthOnly->rgb_fc);
  EXPECT_NO_THROW(models::loadModule(*depthOnly, result.weights_file));
  config.waypoint.predictor.rgb = true;
  models::WaypointPredictor withRgb = models::makeWaypointPredictor(
      config.model, config.waypoint.predictor, 12);
  EXPECT_TRUE(withRgb->rgb_fc);
  EXPECT_THROW(models::loadModule(*withRgb, result.weights_file),
               std::invalid_argument);
}

TEST(WaypointPretrainerTest, TrainBinaryRunsTheShippedConfigAndRefusesResume) {
  const fs::path binary = vln::test::binaryPath() / "bin" / "train";
  if (!fs::exists(binary)) GTEST_SKIP() << "build the train binary first";
  const test::TinyWorld& world = test::tinyWorld();
  vln::test::TempDir dir;
  std::string command =
      binary.string() + " --config " +
      (vln::test::sourcePath() / "configs" / "waypoint" / "predictor.yaml")
          .string();
  for (const std::string set :
       {"sim.rgb.width=32", "sim.rgb.height=32", "sim.depth.width=32",
        "sim.depth.height=32", "model.rgb_width=32", "model.rgb_height=32",
        "model.depth_width=32", "model.depth_height=32",
        "panorama.rgb.width=32", "panorama.rgb.height=32",
        "panorama.depth.width=32", "panorama.depth.height=32",
        "model.rgb_weights=", "model.depth_weights=",
        "waypoint.headings_per_node=1", "waypoint.max_nodes_per_house=3",
        "waypoint.epochs=1", "output.log_level=warn"})
    command += " --set " + set;
  command += " --set dataset.data_path=" + world.data.string() +
             " --set sim.scenes_dir=" + world.scenes.string() +
             " --set output.dir=" + (dir / "run").string() + " 2>&1";
  std::string output;
  ASSERT_EQ(vln::test::runCommand(command, &output), 0) << output;
  EXPECT_TRUE(fs::exists(dir / "run" / "waypoint_predictor.pt"));
  const nlohmann::json metrics =
      common::readJsonFile(dir / "run" / "pretrain_metrics.json");
  EXPECT_EQ(metrics["task"], "waypoint_predictor");
  EXPECT_GT(metrics["eval_panoramas"].get<int>(), 0);
  EXPECT_NE(vln::test::runCommand(command + " --resume", &output), 0);
  EXPECT_THAT(output, HasSubstr("cannot resume"));
}

TEST(WaypointPretrainerTest, RefusesAnotherTask) {
  ExperimentConfig c = tinyConfig(test::TinyWorld{}, "unused");
  c.trainer.task = "rgb_semantic";
  EXPECT_THROW(WaypointPretrainer(c, "unused"), std::invalid_argument);
}

}  // namespace
}  // namespace vln::train
