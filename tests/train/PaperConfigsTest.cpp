// Tests of the run configs in configs/paper/ (paper scale, see
// docs/paper_scale.md) and configs/experiments/ (CPU scale), loaded through
// train::loadExperimentConfig() (src/train/ExperimentConfig.cpp): both sets
// hold the same runs; every run does what its file name says (policy,
// ablations, progress monitor, DAgger, DA* fine-tuning of the run it names,
// augmentation, run directory); the paper-scale files hold the paper's
// observation and model sizes and hyper-parameters (Sections 3.1, 4 and 5);
// and every distinct model builds on the CPU and acts one step on
// observations of its configured size. The weight files and CUDA the paper
// configs name are not needed: the device is forced to cpu and the weight
// keys are cleared (encoders are then randomly initialised).

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <filesystem>
#include <iterator>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "models/ObservationEncoder.h"
#include "models/Policy.h"
#include "support/TestPaths.h"
#include "train/ExperimentConfig.h"

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using Shape = std::vector<int64_t>;

// the shared settings of configs/paper/, not a run of its own
constexpr const char* kPaperBase = "base";

fs::path paperDir() { return vln::test::sourcePath() / "configs" / "paper"; }
fs::path experimentsDir() {
  return vln::test::sourcePath() / "configs" / "experiments";
}

// The .yaml files of `dir` by name.
std::vector<fs::path> yamlFiles(const fs::path& dir) {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.is_regular_file() && entry.path().extension() == ".yaml")
      files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

// The run files of `dir` (paper: without base.yaml).
std::vector<fs::path> runFiles(const fs::path& dir) {
  std::vector<fs::path> files = yamlFiles(dir);
  std::erase_if(files,
                [](const fs::path& f) { return f.stem() == kPaperBase; });
  return files;
}

std::set<std::string> stems(const std::vector<fs::path>& files) {
  std::set<std::string> names;
  for (const auto& f : files) names.insert(f.stem().string());
  return names;
}

Shape sizesOf(const torch::Tensor& t) {
  return Shape(t.sizes().begin(), t.sizes().end());
}

// What a run's file name promises:
// <policy>[_no_<input>][_pm][_da][_aug][_tune].
struct RunTraits {
  models::PolicyType policy = models::PolicyType::kSeq2Seq;
  bool no_rgb = false;
  bool no_depth = false;
  bool no_instruction = false;
  bool pm = false;
  bool dagger = false;
  bool aug = false;
  /// DA*: DAgger with Aug fine-tunes an Aug run (kDaStarSources); the
  /// fine-tuning itself uses the original data.
  bool fine_tune = false;
  /// Aug's second stage (VLN-CE's *_aug_tune): teacher forcing on the
  /// original data from the best checkpoint of the name without "_tune".
  bool aug_tune = false;
  std::string fine_tunes;
};

// The run each DA* run starts from, as VLN-CE's *_da_aug_tune configs load
// it (IL.DAGGER.ckpt_to_load): CMA's from the tuned Aug run, the PM runs
// from the Aug run itself.
const std::map<std::string, std::string> kDaStarSources = {
    {"cma_da_aug", "cma_aug_tune"},
    {"cma_pm_da_aug", "cma_pm_aug"},
    {"seq2seq_pm_da_aug", "seq2seq_pm_aug"}};

RunTraits traitsOf(const std::string& name) {
  std::vector<std::string> tokens;
  size_t start = 0;
  for (size_t end; (end = name.find('_', start)) != std::string::npos;
       start = end + 1)
    tokens.push_back(name.substr(start, end - start));
  tokens.push_back(name.substr(start));
  auto has = [&](const std::string& t) {
    return std::find(tokens.begin(), tokens.end(), t) != tokens.end();
  };
  RunTraits r;
  EXPECT_TRUE(tokens[0] == "seq2seq" || tokens[0] == "cma")
      << name << ": a run's name starts with its policy";
  r.policy = tokens[0] == "cma" ? models::PolicyType::kCma
                                : models::PolicyType::kSeq2Seq;
  r.no_rgb = has("image") || has("vision");
  r.no_depth = has("depth") || has("vision");
  r.no_instruction = has("instruction");
  r.pm = has("pm");
  r.dagger = has("da");
  r.aug = has("aug");
  r.fine_tune = r.dagger && r.aug;
  r.aug_tune = has("tune");
  if (r.fine_tune) {
    EXPECT_TRUE(kDaStarSources.count(name)) << name << ": DA* from where?";
    if (kDaStarSources.count(name)) r.fine_tunes = kDaStarSources.at(name);
  }
  if (r.aug_tune) r.fine_tunes = name.substr(0, name.size() - 5);
  return r;
}

// Checks `config` (loaded from `file`) against its file name; runs write to
// <runsRoot>/<name>.
void expectFollowsName(const ExperimentConfig& config, const fs::path& file,
                       const std::string& runsRoot) {
  const std::string name = file.stem().string();
  SCOPED_TRACE(file.string());
  const RunTraits r = traitsOf(name);
  const models::ModelConfig& m = config.model;
  EXPECT_EQ(m.policy, r.policy);
  EXPECT_EQ(m.no_rgb, r.no_rgb);
  EXPECT_EQ(m.no_depth, r.no_depth);
  EXPECT_EQ(m.no_instruction, r.no_instruction);
  EXPECT_EQ(m.progress_monitor, r.pm);
  EXPECT_EQ(config.trainer.dagger_iterations > 0, r.dagger);
  EXPECT_EQ(config.trainer.fine_tune_dagger, r.fine_tune);
  EXPECT_EQ(config.trainer.use_aug, r.aug && !r.fine_tune && !r.aug_tune);
  if (r.fine_tune || r.aug_tune) {
    EXPECT_EQ(config.trainer.init_checkpoint, runsRoot + "/" + r.fine_tunes);
  } else {
    EXPECT_EQ(config.trainer.init_checkpoint, "");
  }
  EXPECT_EQ(config.output.dir, runsRoot + "/" + name);
}

// The paper's settings (Sections 3.1, 4 and 5), shared by every file of
// configs/paper/.
void expectPaperScale(const ExperimentConfig& config, const fs::path& file) {
  SCOPED_TRACE(file.string());
  // 256x256 RGB-D, 90 degrees horizontal field of view
  EXPECT_EQ(config.sim.rgb.width, 256);
  EXPECT_EQ(config.sim.rgb.height, 256);
  EXPECT_FLOAT_EQ(config.sim.rgb.hfov, 90.0f);
  EXPECT_EQ(config.sim.depth.camera.width, 256);
  EXPECT_EQ(config.sim.depth.camera.height, 256);
  EXPECT_FLOAT_EQ(config.sim.depth.camera.hfov, 90.0f);
  // R2R_VLNCE v1-3 on the MP3D meshes (Z-up .glb files)
  EXPECT_EQ(config.sim.scenes_dir, "data/scene_datasets");
  EXPECT_EQ(config.sim.mesh.up_axis, sim::UpAxis::kZ);
  EXPECT_EQ(config.dataset.data_path,
            "data/datasets/R2R_VLNCE_v1-3_preprocessed");
  EXPECT_EQ(config.task.max_episode_steps, 500);
  EXPECT_FLOAT_EQ(config.task.success_distance, 3.0f);
  // ImageNet ResNet-50 (RGB), DD-PPO ResNet-50 (depth), VLN-CE's sizes
  const models::ModelConfig& m = config.model;
  EXPECT_EQ(m.rgb_encoder, models::EncoderType::kResNet50);
  EXPECT_EQ(m.depth_encoder, models::EncoderType::kResNet50);
  EXPECT_EQ(m.rgb_width, 256);
  EXPECT_EQ(m.rgb_height, 256);
  EXPECT_EQ(m.depth_width, 256);
  EXPECT_EQ(m.depth_height, 256);
  EXPECT_NE(m.rgb_weights, "");
  EXPECT_NE(m.depth_weights, "");
  EXPECT_EQ(m.hidden_size, 512);
  EXPECT_EQ(m.instruction_hidden_size, 128);
  EXPECT_EQ(m.vocab_size, 2504);
  EXPECT_EQ(m.embedding_dim, 50);
  EXPECT_EQ(m.device, "cuda");
  // Adam 2.5e-4, 5 episodes per batch, inflection weight 3.2, <= 30 epochs
  const TrainerConfig& t = config.trainer;
  EXPECT_DOUBLE_EQ(t.lr, 2.5e-4);
  EXPECT_EQ(t.batch_size, 5);
  EXPECT_DOUBLE_EQ(t.inflection_weight, 3.2);
  // Aug's second stage: VLN-CE's epochs (cma_aug_tune 45, seq2seq_aug_tune
  // 15), which the paper does not state
  const std::string name = file.stem().string();
  if (name.ends_with("_aug_tune")) {
    EXPECT_EQ(t.epochs, config.model.policy == models::PolicyType::kCma ? 45 : 15);
  } else {
    EXPECT_EQ(t.epochs, 30);
  }
  // VLN-CE's training: the goal expert, sampled DAgger actions, the
  // unclipped progress target, every epoch's checkpoint evaluated
  EXPECT_EQ(t.expert, "goal");
  EXPECT_EQ(t.dagger_action, "sample");
  EXPECT_FALSE(t.clip_progress_target);
  EXPECT_EQ(t.evaluate_every, "epoch");
  // DAgger: 5000 episodes per collection, 4 epochs, beta 0.75^n, and
  // VLN-CE's 10 collections where it is on
  EXPECT_EQ(t.dagger_episodes, 5000);
  EXPECT_EQ(t.dagger_epochs, 4);
  EXPECT_DOUBLE_EQ(t.dagger_beta, 0.75);
  if (t.dagger_iterations > 0) {
    EXPECT_EQ(t.dagger_iterations, 10);
  }
  // early stopping on val_unseen SPL over whole splits
  EXPECT_EQ(config.eval.selection_split, "val_unseen");
  EXPECT_EQ(config.eval.episodes, -1);
  EXPECT_EQ(config.eval.train_eval_episodes, -1);
}

TEST(PaperConfigsTest, BothSetsHoldTheSameRuns) {
  const auto paper = runFiles(paperDir());
  const auto cpu = runFiles(experimentsDir());
  // the paper's 17 runs and three second stages of Aug runs
  EXPECT_EQ(paper.size(), 20u);
  EXPECT_EQ(stems(paper), stems(cpu));
  EXPECT_TRUE(fs::exists(paperDir() / "base.yaml"));
}

TEST(PaperConfigsTest, PaperFilesHoldThePapersSettings) {
  const auto files = yamlFiles(paperDir());
  ASSERT_FALSE(files.empty());
  for (const auto& file : files)
    expectPaperScale(loadExperimentConfig(file), file);
}

TEST(PaperConfigsTest, EveryRunDoesWhatItsNameSays) {
  for (const auto& file : runFiles(paperDir()))
    expectFollowsName(loadExperimentConfig(file), file, "runs/paper");
  for (const auto& file : runFiles(experimentsDir()))
    expectFollowsName(loadExperimentConfig(file), file, "runs/experiments");
}

// init_checkpoint is loaded strictly, so a DA* or *_aug_tune run and the
// run it fine-tunes must build the same network; the latter must be an Aug
// run of the same set.
TEST(PaperConfigsTest, FineTuningRunsNameARunOfTheSameModel) {
  int fineTuning = 0;
  for (const fs::path& dir : {paperDir(), experimentsDir()}) {
    for (const auto& file : runFiles(dir)) {
      const RunTraits r = traitsOf(file.stem().string());
      if (!r.fine_tune && !r.aug_tune) continue;
      ++fineTuning;
      SCOPED_TRACE(file.string());
      const fs::path source = dir / (r.fine_tunes + ".yaml");
      ASSERT_TRUE(fs::exists(source)) << source;
      const ExperimentConfig config = loadExperimentConfig(file);
      const ExperimentConfig base = loadExperimentConfig(source);
      EXPECT_TRUE(config.model == base.model);
      EXPECT_TRUE(base.trainer.use_aug || traitsOf(r.fine_tunes).aug_tune);
      EXPECT_FALSE(base.trainer.fine_tune_dagger);
      EXPECT_EQ(config.trainer.init_checkpoint, base.output.dir);
    }
  }
  // seq2seq_pm_da_aug, cma_pm_da_aug, cma_da_aug and three *_aug_tune in
  // each set
  EXPECT_EQ(fineTuning, 12);
}

// Every distinct model of both sets (built once each) on the CPU: the policy
// with random word embeddings, the observation encoder, and one acting step
// from random observations of the configured sizes. The paper's ResNet-50
// pair is ~120 MB of parameters and a fraction of a second per image.
TEST(PaperConfigsTest, EveryModelBuildsAndActsOnTheCpu) {
  // each distinct model config with the files that use it
  std::vector<std::pair<models::ModelConfig, std::vector<std::string>>>
      distinct;
  for (const fs::path& dir : {paperDir(), experimentsDir()}) {
    for (const auto& file : yamlFiles(dir)) {
      models::ModelConfig m = loadExperimentConfig(file).model;
      m.device = "cpu";
      m.rgb_weights.clear();
      m.depth_weights.clear();
      auto it = std::find_if(distinct.begin(), distinct.end(),
                             [&](const auto& e) { return e.first == m; });
      if (it == distinct.end()) {
        distinct.emplace_back(m, std::vector<std::string>{});
        it = std::prev(distinct.end());
      }
      it->second.push_back(file.string());
    }
  }
  // seq2seq, its four ablations, seq2seq PM, cma, cma PM, at each scale
  EXPECT_EQ(distinct.size(), 16u);

  torch::NoGradGuard noGrad;
  for (const auto& [m, files] : distinct) {
    SCOPED_TRACE(::testing::PrintToString(files));
    torch::manual_seed(0);
    torch::Tensor embeddings;
    if (m.usesInstruction())
      embeddings = torch::randn({m.vocab_size, m.embedding_dim});
    const auto policy = models::makePolicy(m, embeddings);
    policy->eval();
    models::ObservationEncoder encoder(m);
    encoder->loadPretrained();  // no weight files: a no-op
    encoder->eval();
    EXPECT_EQ(static_cast<bool>(encoder->rgb), m.usesRgb());
    EXPECT_EQ(static_cast<bool>(encoder->depth), m.usesDepth());

    const int64_t batch = 1;
    torch::Tensor rgb, depth, tokens;
    if (m.usesRgb())
      rgb = torch::randint(0, 256, {batch, m.rgb_height, m.rgb_width, 3},
                           torch::kUInt8);
    if (m.usesDepth())
      depth = torch::rand({batch, m.depth_height, m.depth_width, 1});
    if (m.usesInstruction())
      tokens = torch::randint(1, m.vocab_size, {batch, 12}, torch::kInt64);
    const models::VisualFeatures features = encoder->forward(rgb, depth);
    EXPECT_EQ(features.rgb.defined(), m.usesRgb());
    EXPECT_EQ(features.depth.defined(), m.usesDepth());
    if (m.usesRgb()) {
      const models::FeatureShape r = models::rgbFeatureShape(m);
      EXPECT_EQ(sizesOf(features.rgb), (Shape{batch, r[0], r[1], r[2]}));
    }
    if (m.usesDepth()) {
      const models::FeatureShape d = models::depthFeatureShape(m);
      EXPECT_EQ(sizesOf(features.depth), (Shape{batch, d[0], d[1], d[2]}));
    }

    const models::EncodedInstruction instruction =
        policy->encodeInstruction(tokens);
    const models::PolicyInputs inputs{features.rgb, features.depth,
                                      torch::zeros({batch}, torch::kInt64),
                                      torch::zeros({batch})};
    const models::PolicyOutputs out =
        policy->step(instruction, inputs, policy->initialHidden(batch));
    EXPECT_EQ(sizesOf(out.logits), (Shape{batch, models::kNumActions}));
    EXPECT_TRUE(out.logits.isfinite().all().item<bool>());
    EXPECT_EQ(out.progress.defined(), m.progress_monitor);
    if (m.progress_monitor) {
      EXPECT_EQ(sizesOf(out.progress), (Shape{batch}));
    }
    EXPECT_EQ(sizesOf(out.hidden),
              (Shape{batch, m.recurrentStateRows(), m.hidden_size}));
  }
}

}  // namespace
}  // namespace vln::train
