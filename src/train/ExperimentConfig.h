#pragma once
// The root configuration of a run: one YAML file with one section per
// module's config struct (sim, task, dataset, model, trainer, pretrain, eval,
// output). Loaded strictly: unknown keys, wrong types and out-of-range values
// are errors naming the key path and the file. The resolved config is written
// next to a run's outputs (config.yaml) and embedded in its checkpoints.

#include <filesystem>
#include <string>
#include <vector>

#include "common/Config.h"
#include "data/DatasetConfig.h"
#include "models/ModelConfig.h"
#include "rollout/EvalConfig.h"
#include "sim/SimConfig.h"
#include "world/HouseConfig.h"

namespace vln::train {

/// Imitation learning of the VLN policy (paper Sections 4.3 and 5).
struct TrainerConfig {
  /// What the run trains: the VLN policy, or one of the encoder pretraining
  /// tasks that stand in for the downloads the paper uses.
  std::string task = "vln";
  /// Seed of everything random in the run (episode order, DAgger coins,
  /// initialisation).
  int seed = 0;
  /// Threads for LibTorch intra-op parallelism (LibTorch here defaults to 1).
  int torch_threads = 2;
  /// Environments stepped together while collecting.
  int num_envs = 8;
  /// Threads stepping/rendering environments while collecting.
  int env_threads = 2;
  /// Collection encodes observations and steps the policy one environment
  /// at a time, so an episode's features and actions do not depend on the
  /// episodes sharing its batch (batched float arithmetic rounds
  /// differently for other batch shapes). A round resumed after a kill then
  /// stores exactly what an uninterrupted run stores and training continues
  /// bit for bit. Off: batched and faster; a resumed round's features
  /// differ from an uninterrupted run's by float rounding (~1e-4).
  bool exact_resume = false;

  /// Adam learning rate (paper: 2.5e-4).
  double lr = 2.5e-4;
  /// Whole episodes per update (paper: 5).
  int batch_size = 5;
  /// Inflection weighting coefficient (paper: 3.2); <= 0 computes it as the
  /// inverse inflection frequency of the training ground truth.
  double inflection_weight = 3.2;
  /// Weight alpha of the progress-monitor MSE (used when
  /// model.progress_monitor).
  double progress_loss_weight = 1.0;
  /// Clip the gradient norm to this value (0: no clipping).
  double grad_clip = 0.0;

  /// Teacher-forcing epochs over the oracle trajectories (paper: up to 30,
  /// early-stopped on val_unseen). Used when dagger_iterations == 0.
  int epochs = 30;
  /// DAgger iterations (0: teacher forcing only). Iteration n takes the
  /// oracle action with probability beta = dagger_beta^n (n+1 when
  /// fine_tune_dagger), collects dagger_episodes episodes, appends them to
  /// the aggregated store and trains dagger_epochs epochs on all of it.
  int dagger_iterations = 0;
  int dagger_episodes = 5000;
  int dagger_epochs = 4;
  double dagger_beta = 0.75;
  /// The paper's DA*: beta = dagger_beta^(n+1), for fine-tuning from
  /// init_checkpoint.
  bool fine_tune_dagger = false;
  /// Policy weights to start from (strictly loaded; empty: fresh init): a
  /// checkpoint, a run directory (its best checkpoint by selection-split
  /// SPL, else its latest) or a tensor file.
  std::string init_checkpoint;

  /// Mix the dataset's augmentation split into teacher forcing (paper "Aug").
  bool use_aug = false;

  /// Store encoder features in fp16 in the on-disk store (half the bytes).
  bool store_fp16 = true;
  /// LMDB map size of the feature store, GiB.
  double store_max_gib = 64.0;

  /// Evaluate on eval.splits after every epoch (teacher forcing) or DAgger
  /// iteration and keep the best checkpoint by eval.selection_split SPL.
  bool eval_during_training = true;
  /// Stop after this many evaluations without SPL improvement (0: never).
  int early_stopping_patience = 0;
  /// Abort after this many consecutive non-finite losses (each one skips
  /// its update and is counted).
  int max_nonfinite_updates = 5;
  /// Log a training line every this many updates.
  int log_every_updates = 20;

  /// Data-parallel training over several processes (docs/distributed.md):
  /// auto trains with every process of a torchrun-style launch when the
  /// environment sets WORLD_SIZE > 1; off always trains in this process
  /// alone (WORLD_SIZE is then ignored).
  std::string distributed = "auto";
  /// Collective backend: auto (nccl when model.device is a GPU and this
  /// LibTorch has NCCL, else gloo), gloo, nccl.
  std::string distributed_backend = "auto";
  /// Rendezvous and every collective (gradient all-reduce, ...) fail after
  /// this many seconds.
  double distributed_timeout_s = 600.0;
  /// How long a rank waits for the others at the end of a collection round
  /// or an evaluation (uneven phases), seconds.
  double distributed_wait_s = 86400.0;
  /// Gradients are all-reduced in flat buckets of at most this many MiB.
  double distributed_bucket_mib = 25.0;

  void visit(common::ConfigVisitor& v) {
    v.choice("task", task, {"vln", "depth_pointnav", "rgb_semantic"},
             "What to train");
    v.field("seed", seed, "Seed of the run", common::atLeast(0));
    v.field("torch_threads", torch_threads, "LibTorch threads",
            common::inRange(1, 256));
    v.field("num_envs", num_envs, "Environments stepped together",
            common::inRange(1, 1024));
    v.field("env_threads", env_threads, "Environment threads",
            common::inRange(1, 256));
    v.field("exact_resume", exact_resume,
            "Collect one environment at a time (bitwise-exact resume)");
    v.field("lr", lr, "Adam learning rate", common::inRange(0.0, 1.0));
    v.field("batch_size", batch_size, "Episodes per update",
            common::inRange(1, 100000));
    v.field("inflection_weight", inflection_weight,
            "Inflection weight (<= 0: inverse inflection frequency)",
            common::inRange(-1.0, 1000.0));
    v.field("progress_loss_weight", progress_loss_weight,
            "Progress-monitor loss weight alpha", common::inRange(0.0, 1000.0));
    v.field("grad_clip", grad_clip, "Gradient norm clip (0: none)",
            common::inRange(0.0, 1e6));
    v.field("epochs", epochs, "Teacher-forcing epochs",
            common::inRange(0, 100000));
    v.field("dagger_iterations", dagger_iterations,
            "DAgger iterations (0: teacher forcing only)",
            common::inRange(0, 100000));
    v.field("dagger_episodes", dagger_episodes, "Episodes per DAgger iteration",
            common::inRange(1, 10000000));
    v.field("dagger_epochs", dagger_epochs, "Epochs per DAgger iteration",
            common::inRange(1, 100000));
    v.field("dagger_beta", dagger_beta, "DAgger oracle probability base",
            common::inRange(0.0, 1.0));
    v.field("fine_tune_dagger", fine_tune_dagger,
            "DA*: beta = dagger_beta^(n+1)");
    v.field("init_checkpoint", init_checkpoint,
            "Checkpoint, run directory (its best checkpoint) or tensor file to "
            "start from (empty: fresh)");
    v.field("use_aug", use_aug, "Mix the augmentation split into training");
    v.field("store_fp16", store_fp16, "Store features as fp16");
    v.field("store_max_gib", store_max_gib, "Feature store map size (GiB)",
            common::inRange(0.01, 1e6));
    v.field("eval_during_training", eval_during_training,
            "Evaluate after every epoch / DAgger iteration");
    v.field("early_stopping_patience", early_stopping_patience,
            "Evaluations without improvement before stopping (0: never)",
            common::atLeast(0));
    v.field("max_nonfinite_updates", max_nonfinite_updates,
            "Consecutive non-finite losses before aborting",
            common::inRange(1, 1000000));
    v.field("log_every_updates", log_every_updates, "Updates per log line",
            common::atLeast(1));
    v.choice(
        "distributed", distributed, {"auto", "off"},
        "Multi-process training when WORLD_SIZE > 1 (auto) or never (off)");
    v.choice("distributed_backend", distributed_backend,
             {"auto", "gloo", "nccl"}, "Collective backend");
    v.field("distributed_timeout_s", distributed_timeout_s,
            "Rendezvous and collective timeout (s)", common::inRange(0.1, 1e7));
    v.field("distributed_wait_s", distributed_wait_s,
            "Wait for the other ranks after collection/evaluation (s)",
            common::inRange(0.1, 1e8));
    v.field("distributed_bucket_mib", distributed_bucket_mib,
            "Gradient all-reduce bucket size (MiB)",
            common::inRange(0.001, 1e5));
  }
  bool operator==(const TrainerConfig&) const = default;
};

/// Encoder pretraining on tasks the procedural world supports, standing in
/// for ImageNet (RGB) and DD-PPO point-goal navigation (depth).
struct PretrainConfig {
  /// Houses (generated by seed) used for pretraining; held-out houses for
  /// the reported metrics come after them.
  int train_houses = 24;
  int heldout_houses = 6;
  /// Seed of the first pretraining house (kept apart from the VLN houses).
  int house_seed = 100000;
  /// Point-goal episodes per DAgger iteration / semantic images per epoch.
  int samples = 2000;
  /// DAgger iterations (point-goal) or epochs (semantic).
  int iterations = 4;
  /// Epochs over the aggregated point-goal data per iteration.
  int epochs_per_iteration = 2;
  /// Held-out evaluation episodes / images.
  int eval_samples = 200;
  /// Point-goal success radius (DD-PPO: 0.2 m) and geodesic range of goals.
  float success_distance = 0.2f;
  float min_goal_distance = 1.0f;
  float max_goal_distance = 8.0f;
  /// Where the trained encoder weights go (a TorchScript tensor file that
  /// model.rgb_weights / model.depth_weights can point at).
  std::string encoder_out;
  /// Generation parameters of the pretraining houses.
  world::HouseConfig house;
  /// Adam learning rate of both pretraining tasks.
  double lr = 1e-3;
  /// Point-goal episodes / semantic images per update.
  int batch_size = 16;
  /// Hidden size of the point-goal policy's GRU (DD-PPO: 512).
  int hidden_size = 128;
  /// Semantic task: an object is "in view" when it covers at least this
  /// fraction of the image's pixels.
  float min_object_fraction = 0.02f;
  /// Point-goal task: the aggregated DAgger frames may hold at most this
  /// much memory (depth is kept as uint16), GiB.
  double max_memory_gib = 4.0;

  void visit(common::ConfigVisitor& v) {
    v.field("train_houses", train_houses, "Pretraining houses",
            common::inRange(1, 100000));
    v.field("heldout_houses", heldout_houses, "Held-out houses",
            common::inRange(1, 100000));
    v.field("house_seed", house_seed, "Seed of the first house",
            common::atLeast(0));
    v.field("samples", samples,
            "Episodes (point-goal) or images (semantic) per iteration",
            common::inRange(1, 100000000));
    v.field("iterations", iterations, "DAgger iterations or epochs",
            common::inRange(1, 100000));
    v.field("epochs_per_iteration", epochs_per_iteration,
            "Epochs per DAgger iteration", common::inRange(1, 100000));
    v.field("eval_samples", eval_samples, "Held-out evaluation samples",
            common::inRange(1, 10000000));
    v.field("success_distance", success_distance,
            "Point-goal success radius (m)", common::inRange(0.01, 10.0));
    v.field("min_goal_distance", min_goal_distance, "Nearest goal (geodesic m)",
            common::inRange(0.0, 100.0));
    v.field("max_goal_distance", max_goal_distance,
            "Farthest goal (geodesic m)", common::inRange(0.1, 1000.0));
    v.field("encoder_out", encoder_out,
            "Output file of the trained encoder weights");
    v.section("house", house, "Pretraining house generation");
    v.field("lr", lr, "Adam learning rate", common::inRange(0.0, 1.0));
    v.field("batch_size", batch_size,
            "Episodes (point-goal) or images (semantic) per update",
            common::inRange(1, 100000));
    v.field("hidden_size", hidden_size, "Point-goal policy GRU size",
            common::inRange(1, 65536));
    v.field("min_object_fraction", min_object_fraction,
            "Smallest image fraction of an object labelled in view",
            common::inRange(0.0, 1.0));
    v.field("max_memory_gib", max_memory_gib,
            "Memory bound of the aggregated point-goal frames (GiB)",
            common::inRange(0.001, 1e6));
  }
  bool operator==(const PretrainConfig&) const = default;
};

/// Where a run writes and how it logs.
struct OutputConfig {
  /// Run directory: config.yaml, checkpoints/, store/, logs, metrics.
  std::string dir = "runs/default";
  /// spdlog level: trace, debug, info, warn, error.
  std::string log_level = "info";
  /// Write TensorBoard event files (tfevents) beside the JSON-lines metrics.
  bool tensorboard = true;
  /// Checkpoints kept besides the best one (-1: all).
  int keep_checkpoints = -1;

  void visit(common::ConfigVisitor& v) {
    v.field("dir", dir, "Run directory");
    v.choice("log_level", log_level,
             {"trace", "debug", "info", "warn", "error"}, "Log level");
    v.field("tensorboard", tensorboard, "Write TensorBoard event files");
    v.field("keep_checkpoints", keep_checkpoints,
            "Checkpoints kept besides the best (-1: all)", common::atLeast(-1));
  }
  bool operator==(const OutputConfig&) const = default;
};

/// The whole run.
struct ExperimentConfig {
  sim::SimConfig sim;
  sim::TaskConfig task;
  data::DatasetConfig dataset;
  models::ModelConfig model;
  TrainerConfig trainer;
  PretrainConfig pretrain;
  rollout::EvalConfig eval;
  OutputConfig output;

  void visit(common::ConfigVisitor& v) {
    v.section("sim", sim,
              "Simulator: scenes, navmesh, agent, cameras, renderer");
    v.section("task", task, "Episode rules");
    v.section("dataset", dataset, "Episode splits and embeddings");
    v.section("model", model, "Policy and encoders");
    v.section("trainer", trainer, "Imitation learning");
    v.section("pretrain", pretrain, "Encoder pretraining tasks");
    v.section("eval", eval, "Evaluation");
    v.section("output", output, "Run directory and logging");
  }
  bool operator==(const ExperimentConfig&) const = default;

  /// Cross-section checks: camera sizes equal the model's image sizes,
  /// model.validate(), and the like. Throws std::invalid_argument naming the
  /// keys involved.
  void validate() const;
};

/// Loads a run config: the file, its `_base_` includes, then `overrides`
/// ("section.key=value"), then validate(). Errors name the file and key.
ExperimentConfig loadExperimentConfig(
    const std::filesystem::path& file,
    const std::vector<std::string>& overrides = {});

/// The resolved config as documented YAML.
std::string experimentConfigYaml(const ExperimentConfig& config);

}  // namespace vln::train
