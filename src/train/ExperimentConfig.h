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
#include "rollout/WaypointAgentConfig.h"
#include "sim/Panorama.h"
#include "sim/SimConfig.h"
#include "train/TextPretrainConfig.h"
#include "train/WaypointPretrainConfig.h"
#include "world/HouseConfig.h"

namespace vln::train {

/// Imitation learning of the VLN policy (paper Sections 4.3 and 5).
struct TrainerConfig {
  std::string task = "vln";
  int seed = 0;
  int torch_threads = 2;
  int num_envs = 8;
  int env_threads = 2;
  // exact_resume: batched float arithmetic rounds differently for other
  // batch shapes, so batched features depend on the episodes sharing a batch
  bool exact_resume = false;

  double lr = 2.5e-4;
  /// Multiplier of the learning rate per DAgger iteration (1: constant).
  double lr_decay = 1.0;
  /// Within a round: "constant", or "cosine" (each round's epochs anneal
  /// from its rate towards zero along half a cosine).
  std::string lr_schedule = "constant";
  int batch_size = 5;
  double inflection_weight = 3.2;
  double progress_loss_weight = 1.0;
  double instruction_contrast_weight = 0.0;
  double grad_clip = 0.0;

  int epochs = 30;
  int dagger_iterations = 0;
  int dagger_episodes = 5000;
  int dagger_epochs = 4;
  double dagger_beta = 0.75;
  bool fine_tune_dagger = false;
  std::string init_checkpoint;

  bool use_aug = false;
  std::string expert = "goal";
  std::string dagger_action = "sample";
  bool clip_progress_target = false;
  std::string evaluate_every = "epoch";

  std::string mode = "dagger";
  int effective_batch_size = -1;
  int max_traj_len = -1;
  int preload_size = 30;

  bool store_fp16 = true;
  double store_max_gib = 64.0;

  bool eval_during_training = true;
  int early_stopping_patience = 0;
  int max_nonfinite_updates = 5;
  int log_every_updates = 20;

  std::string distributed = "auto";
  std::string distributed_backend = "auto";
  double distributed_timeout_s = 600.0;
  double distributed_wait_s = 86400.0;
  double distributed_bucket_mib = 25.0;

  void visit(common::ConfigVisitor& v) {
    v.choice("task", task,
             {"vln", "depth_pointnav", "rgb_semantic", "text_mlm",
              "waypoint_predictor", "waypoint_cma"},
             "What the run trains: the VLN policy, or one of the encoder "
             "pretraining tasks that stand in for the downloads the paper uses "
             "(text_mlm: the text encoder of RxR's instruction features), or "
             "the candidate-waypoint predictor (waypoint_predictor), or the "
             "CMA agent over candidate waypoints (waypoint_cma, "
             "`waypoint_agent:`)");
    v.field("seed", seed,
            "Seed of everything random in the run (episode order, DAgger "
            "coins, initialisation)",
            common::atLeast(0));
    v.field("torch_threads", torch_threads,
            "Threads for LibTorch intra-op parallelism (LibTorch here defaults "
            "to 1)",
            common::inRange(1, 256));
    v.field("num_envs", num_envs,
            "Environments stepped together while collecting",
            common::inRange(1, 1024));
    v.field("env_threads", env_threads,
            "Threads stepping and rendering environments while collecting",
            common::inRange(1, 256));
    v.field("exact_resume", exact_resume,
            "Collect one environment at a time, so that an episode's features "
            "and actions do not depend on the episodes sharing its batch and "
            "a round resumed after a kill continues bit for bit (off: batched "
            "and faster; a resumed round's features then differ by float "
            "rounding, ~1e-4)");
    v.field("lr", lr, "Adam learning rate (paper: 2.5e-4)",
            common::inRange(0.0, 1.0));
    v.field("lr_decay", lr_decay,
            "Learning-rate multiplier per DAgger iteration: iteration n's "
            "epochs train at lr * lr_decay^n (1: constant, as VLN-CE; "
            "teacher forcing is iteration 0)",
            common::inRange(1e-6, 1.0));
    v.choice("lr_schedule", lr_schedule, {"constant", "cosine"},
             "Learning rate over a round's epochs: constant, or cosine: "
             "epoch e of E trains at the round's rate x (1 + cos(pi e / "
             "E)) / 2, so the last epochs take small steps");
    v.field("batch_size", batch_size, "Whole episodes per update (paper: 5)",
            common::inRange(1, 100000));
    v.field("inflection_weight", inflection_weight,
            "Inflection weighting coefficient (paper: 3.2); <= 0 computes it "
            "as the inverse inflection frequency of the training ground truth",
            common::inRange(-1.0, 1000.0));
    v.field("progress_loss_weight", progress_loss_weight,
            "Weight alpha of the progress-monitor MSE (with "
            "model.progress_monitor)",
            common::inRange(0.0, 1000.0));
    v.field("instruction_contrast_weight", instruction_contrast_weight,
            "Weight of the instruction-contrast loss: the oracle's action "
            "(or waypoint) must be more likely under the episode's "
            "instruction than under another episode's of the batch (0: off)",
            common::inRange(0.0, 1000.0));
    v.field("grad_clip", grad_clip,
            "Clip the gradient norm to this value (0: no clipping)",
            common::inRange(0.0, 1e6));
    v.field("epochs", epochs,
            "Teacher-forcing epochs over the oracle trajectories, when "
            "dagger_iterations is 0 (paper: up to 30, early-stopped on "
            "val_unseen)",
            common::inRange(0, 100000));
    v.field("dagger_iterations", dagger_iterations,
            "DAgger iterations (0: teacher forcing only); iteration n takes "
            "the oracle action with probability beta = dagger_beta^n (n+1 "
            "with fine_tune_dagger), collects dagger_episodes episodes into "
            "the aggregated store and trains dagger_epochs epochs on all of it",
            common::inRange(0, 100000));
    v.field("dagger_episodes", dagger_episodes,
            "Episodes collected per DAgger iteration (paper: 5000)",
            common::inRange(1, 10000000));
    v.field("dagger_epochs", dagger_epochs,
            "Epochs over the aggregated store per DAgger iteration (paper: 4)",
            common::inRange(1, 100000));
    v.field("dagger_beta", dagger_beta,
            "Base of the DAgger oracle probability beta (paper: 0.75)",
            common::inRange(0.0, 1.0));
    v.field("fine_tune_dagger", fine_tune_dagger,
            "The paper's DA*: beta = dagger_beta^(n+1), for fine-tuning from "
            "init_checkpoint");
    v.field("init_checkpoint", init_checkpoint,
            "Policy weights to start from, strictly loaded: a checkpoint, a "
            "run directory (its best checkpoint by selection-split SPL, else "
            "its latest) or a tensor file (empty: fresh init)");
    v.field("use_aug", use_aug,
            "Mix the dataset's augmentation split into teacher forcing (paper: "
            "Aug)");
    v.choice("expert", expert, {"goal", "reference_path"},
             "The oracle of teacher forcing and DAgger: goal is VLN-CE's "
             "ShortestPathSensor (the shortest-path action to the episode's "
             "goal, STOP within task.follower_goal_radius); reference_path "
             "follows the reference path's waypoints in order, as the "
             "ground truth was generated, so an agent that drifted past a "
             "waypoint is sent back to it");
    v.choice("dagger_action", dagger_action, {"sample", "argmax"},
             "The policy's action where DAgger does not take the oracle's: "
             "sampled from its softmax (VLN-CE) or its most likely action");
    v.field("clip_progress_target", clip_progress_target,
            "Clip the progress monitor's target (d0 - d) / d0 to [-1, 1], "
            "the range of its tanh head (VLN-CE does not: more than 2 d0 "
            "from the goal the target is below -1)");
    v.choice("evaluate_every", evaluate_every, {"epoch", "iteration"},
             "DAgger: evaluate (and keep as a candidate for the best "
             "checkpoint) after every epoch, as VLN-CE evaluates every saved "
             "checkpoint, or only after each iteration's last epoch "
             "(teacher forcing evaluates every epoch either way)");
    v.choice("mode", mode, {"dagger", "recollect"},
             "How episodes reach the learner (docs/paper_scale.md): dagger "
             "collects them once into the feature store (teacher forcing is "
             "its first round, beta = 1; VLN-CE's dagger_trainer); recollect "
             "re-simulates the dataset's ground-truth action sequences "
             "(<split>_gt.json.gz) every epoch and trains on them without a "
             "store (VLN-CE's recollect_trainer; teacher forcing only)");
    v.field("effective_batch_size", effective_batch_size,
            "mode recollect: episodes per optimizer step by gradient "
            "accumulation over effective_batch_size / batch_size batches, "
            "a multiple of batch_size (-1: one batch per step; VLN-CE's "
            "IL.RECOLLECT_TRAINER.effective_batch_size)",
            common::inRange(-1, 10000000));
    v.field("max_traj_len", max_traj_len,
            "mode recollect: episodes whose ground truth has more actions "
            "than this are left out of training, as VLN-CE does (-1: none; "
            "VLN-CE's RxR configs: 250)",
            common::inRange(-1, 10000000));
    v.field("preload_size", preload_size,
            "mode recollect: episodes simulated ahead of the updates that "
            "use them and held in memory, rounded up to whole updates "
            "(VLN-CE's IL.RECOLLECT_TRAINER.preload_size); at least "
            "batch_size",
            common::inRange(1, 10000000));
    v.field("store_fp16", store_fp16,
            "Store encoder features as fp16 in the on-disk store (half the "
            "bytes)");
    v.field("store_max_gib", store_max_gib,
            "LMDB map size of the feature store (GiB)",
            common::inRange(0.01, 1e6));
    v.field("eval_during_training", eval_during_training,
            "Evaluate on eval.splits after every epoch (teacher forcing) or "
            "DAgger iteration and keep the best checkpoint by "
            "eval.selection_split SPL");
    v.field("early_stopping_patience", early_stopping_patience,
            "Stop after this many evaluations without SPL improvement (0: "
            "never)",
            common::atLeast(0));
    v.field("max_nonfinite_updates", max_nonfinite_updates,
            "Abort after this many consecutive non-finite losses (each one "
            "skips its update and is counted)",
            common::inRange(1, 1000000));
    v.field("log_every_updates", log_every_updates,
            "Log a training line every this many updates", common::atLeast(1));
    v.choice("distributed", distributed, {"auto", "off"},
             "Data-parallel training over several processes "
             "(docs/distributed.md): auto trains with every process of a "
             "torchrun-style launch when WORLD_SIZE > 1, off always trains in "
             "this process alone");
    v.choice("distributed_backend", distributed_backend,
             {"auto", "gloo", "nccl"},
             "Collective backend (auto: nccl when model.device is a GPU and "
             "this LibTorch has NCCL, else gloo)");
    v.field("distributed_timeout_s", distributed_timeout_s,
            "Rendezvous and every collective (gradient all-reduce, ...) fail "
            "after this long (s)",
            common::inRange(0.1, 1e7));
    v.field("distributed_wait_s", distributed_wait_s,
            "How long a rank waits for the others at the end of a collection "
            "round or an evaluation, phases of uneven length (s)",
            common::inRange(0.1, 1e8));
    v.field("distributed_bucket_mib", distributed_bucket_mib,
            "Gradients are all-reduced in flat buckets of at most this size "
            "(MiB)",
            common::inRange(0.001, 1e5));
  }
  bool operator==(const TrainerConfig&) const = default;
};

/// Encoder pretraining on tasks the procedural world supports, standing in
/// for ImageNet (RGB) and DD-PPO point-goal navigation (depth).
struct PretrainConfig {
  int train_houses = 24;
  int heldout_houses = 6;
  int house_seed = 100000;
  int samples = 2000;
  int iterations = 4;
  int epochs_per_iteration = 2;
  int eval_samples = 200;
  float success_distance = 0.2f;
  float min_goal_distance = 1.0f;
  float max_goal_distance = 8.0f;
  std::string encoder_out;
  world::HouseConfig house;
  double lr = 1e-3;
  /// "constant", or "cosine" (trainer.lr_schedule's shape over a round).
  std::string lr_schedule = "constant";
  int batch_size = 16;
  int hidden_size = 128;
  float min_object_fraction = 0.02f;
  double max_memory_gib = 4.0;
  TextPretrainConfig text;

  void visit(common::ConfigVisitor& v) {
    v.field("train_houses", train_houses,
            "Houses (generated by seed) that pretraining trains on",
            common::inRange(1, 100000));
    v.field("heldout_houses", heldout_houses,
            "Held-out houses of the reported metrics (generated after the "
            "training houses)",
            common::inRange(1, 100000));
    v.field("house_seed", house_seed,
            "Seed of the first pretraining house (kept apart from the VLN "
            "houses)",
            common::atLeast(0));
    v.field("samples", samples,
            "Point-goal episodes per DAgger iteration or semantic images per "
            "epoch",
            common::inRange(1, 100000000));
    v.field("iterations", iterations,
            "DAgger iterations (point-goal) or epochs (semantic)",
            common::inRange(1, 100000));
    v.field("epochs_per_iteration", epochs_per_iteration,
            "Epochs over the aggregated point-goal data per DAgger iteration",
            common::inRange(1, 100000));
    v.field("eval_samples", eval_samples,
            "Held-out evaluation episodes (point-goal) or images (semantic)",
            common::inRange(1, 10000000));
    v.field("success_distance", success_distance,
            "Point-goal success radius (m; DD-PPO: 0.2)",
            common::inRange(0.01, 10.0));
    v.field("min_goal_distance", min_goal_distance,
            "Nearest point goal (geodesic m)", common::inRange(0.0, 100.0));
    v.field("max_goal_distance", max_goal_distance,
            "Farthest point goal (geodesic m)", common::inRange(0.1, 1000.0));
    v.field("encoder_out", encoder_out,
            "Output file of the trained encoder weights, a TorchScript tensor "
            "file that model.rgb_weights or model.depth_weights can point at");
    v.section("house", house, "Pretraining house generation");
    v.field("lr", lr, "Adam learning rate of both pretraining tasks",
            common::inRange(0.0, 1.0));
    v.choice("lr_schedule", lr_schedule, {"constant", "cosine"},
             "Learning rate over a round's epochs (the semantic task's "
             "epochs; each point-goal DAgger iteration's): constant, or "
             "cosine: epoch e of E trains at lr x (1 + cos(pi e / E)) / 2");
    v.field("batch_size", batch_size,
            "Episodes (point-goal) or images (semantic) per update",
            common::inRange(1, 100000));
    v.field("hidden_size", hidden_size,
            "Hidden size of the point-goal policy's GRU (DD-PPO: 512)",
            common::inRange(1, 65536));
    v.field("min_object_fraction", min_object_fraction,
            "Semantic task: an object is in view when it covers at least this "
            "fraction of the image's pixels",
            common::inRange(0.0, 1.0));
    v.field("max_memory_gib", max_memory_gib,
            "Point-goal task: memory bound of the aggregated DAgger frames, "
            "depth kept as uint16 (GiB)",
            common::inRange(0.001, 1e6));
    v.section("text", text,
              "trainer.task text_mlm: the text encoder, its corpus and the "
              "RxR-layout feature files it writes");
  }
  bool operator==(const PretrainConfig&) const = default;
};

/// Where a run writes and how it logs.
struct OutputConfig {
  std::string dir = "runs/default";
  std::string log_level = "info";
  bool tensorboard = true;
  int keep_checkpoints = -1;

  void visit(common::ConfigVisitor& v) {
    v.field("dir", dir,
            "Run directory: config.yaml, checkpoints/, store/, logs, metrics");
    v.choice("log_level", log_level,
             {"trace", "debug", "info", "warn", "error"}, "Log level (spdlog)");
    v.field("tensorboard", tensorboard,
            "Write TensorBoard event files (tfevents) beside the JSON-lines "
            "metrics");
    v.field("keep_checkpoints", keep_checkpoints,
            "Checkpoints kept besides the best one (-1: all)",
            common::atLeast(-1));
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
  sim::PanoramaConfig panorama;
  WaypointPretrainConfig waypoint;
  rollout::WaypointAgentConfig waypoint_agent;

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
    v.section("panorama", panorama,
              "Panoramic views of the waypoint runs (docs/waypoints.md)");
    v.section("waypoint", waypoint,
              "trainer.task waypoint_predictor: the candidate-waypoint "
              "predictor and its training");
    v.section("waypoint_agent", waypoint_agent,
              "trainer.task waypoint_cma: the agent over candidate waypoints "
              "(docs/waypoints.md)");
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
