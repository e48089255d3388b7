#pragma once
// A tiny procedural R2R_VLNCE world shared by the trainer tests: three
// small houses (two for train/val_seen/train_aug, one for val_unseen),
// generated once per build tree by world::generateWorld and reused by every
// test executable (a file lock serialises the first generation), plus the
// run config of a tiny model on 32x32 images.

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "common/FileIo.h"
#include "data/Glove.h"
#include "data/SubInstructions.h"
#include "support/TestPaths.h"
#include "world/WorldGenerator.h"

namespace vln::train::test {

struct TinyWorld {
  std::filesystem::path data;    ///< dataset root (<data>/<split>/...)
  std::filesystem::path scenes;  ///< sim.scenes_dir
  int vocab_size = 0;
  int embedding_dim = 0;
};

inline world::WorldConfig tinyWorldConfig() {
  world::WorldConfig c;
  c.houses = 3;
  c.seed = 11;
  c.house.min_rooms = 3;
  c.house.max_rooms = 4;
  c.house.floor_hole_probability = 0.0f;
  c.splits.val_unseen_fraction = 0.34f;
  c.splits.test_fraction = 0.0f;
  c.splits.train_per_house = 5;
  c.splits.val_seen_per_house = 2;
  c.splits.val_unseen_per_house = 3;
  c.splits.test_per_house = 0;
  c.splits.aug_per_house = 3;
  c.instructions.per_trajectory = 1;
  c.glove.dim = 8;
  c.glove.epochs = 5;
  // for waypoint_agent.leg_words_only's evaluations (new files only)
  c.splits.evaluation_sub_instructions = true;
  return c;
}

/// The shared tiny world, generated on first use.
inline const TinyWorld& tinyWorld() {
  static const TinyWorld world = [] {
    namespace fs = std::filesystem;
    const fs::path root =
        vln::test::binaryPath() / "tests" / "train_tiny_world";
    fs::create_directories(root);
    TinyWorld w;
    w.data = root / "data";
    w.scenes = root / "scenes";
    const int fd = ::open((root / "lock").c_str(), O_CREAT | O_RDWR, 0644);
    if (fd < 0)
      throw std::runtime_error("tinyWorld(): cannot open the lock file");
    ::flock(fd, LOCK_EX);
    try {
      // a world from before the sub-instruction files is generated again
      if (!fs::exists(root / "done") ||
          !fs::exists(data::splitSubInstructionsPath(w.data, "val_unseen"))) {
        world::WorldOutput output;
        output.out = w.data;
        output.scenes_dir = w.scenes;
        output.threads = 2;
        world::generateWorld(tinyWorldConfig(), output);
        common::writeFileAtomic(root / "done", "ok\n");
      }
    } catch (...) {
      ::flock(fd, LOCK_UN);
      ::close(fd);
      throw;
    }
    ::flock(fd, LOCK_UN);
    ::close(fd);
    const data::EmbeddingMatrix matrix =
        data::readEmbeddingsJson(w.data / "embeddings.json.gz");
    w.vocab_size = matrix.rows;
    w.embedding_dim = matrix.dim;
    return w;
  }();
  return world;
}

/// The tiny model every training test builds, as `model:` keys of a run
/// config (sizes far below any real run's, so that a test trains in
/// seconds), and the `trainer:` section's head: one thread, three
/// environments, batches of three episodes.
inline constexpr const char* kTinyModelYaml =
    "  rgb_encoder: small_cnn\n"
    "  depth_encoder: small_cnn\n"
    "  instruction_hidden_size: 8\n"
    "  hidden_size: 16\n"
    "  prev_action_embedding_dim: 4\n"
    "  rgb_projection_size: 8\n"
    "  depth_projection_size: 8\n"
    "  spatial_embedding_dim: 4\n"
    "  progress_monitor: true\n"
    "  rgb_height: 32\n  rgb_width: 32\n  depth_height: 32\n  depth_width: 32\n";
/// The `sim:` section of a tiny run: the test world's scenes, 32x32 images.
inline std::string tinySimYaml(const std::filesystem::path& scenes) {
  return "sim:\n"
         "  scenes_dir: " +
         scenes.string() +
         "\n"
         "  rgb: {width: 32, height: 32}\n"
         "  depth: {width: 32, height: 32}\n";
}
inline constexpr const char* kTinyTrainerYaml =
    "trainer:\n"
    "  torch_threads: 1\n"
    "  num_envs: 3\n"
    "  env_threads: 1\n"
    "  lr: 0.002\n"
    "  batch_size: 3\n"
    "  store_max_gib: 0.25\n";

/// A run config (YAML) of a tiny Seq2Seq-or-CMA model in `outDir` on the
/// tiny world; `extra` is appended (later keys of a section must not
/// repeat earlier ones, so pass whole extra sections or use --set).
inline std::string tinyRunConfig(const TinyWorld& w,
                                 const std::filesystem::path& outDir,
                                 const std::string& trainer,
                                 const std::string& policy = "cma") {
  return tinySimYaml(w.scenes) +
         "task:\n"
         "  max_episode_steps: 120\n"
         "dataset:\n"
         "  data_path: " +
         w.data.string() +
         "\n"
         "model:\n"
         "  policy: " +
         policy +
         "\n"
         "  vocab_size: " +
         std::to_string(w.vocab_size) +
         "\n"
         "  embedding_dim: " +
         std::to_string(w.embedding_dim) + "\n" + kTinyModelYaml +
         kTinyTrainerYaml +
         "  log_every_updates: 2\n" +
         trainer +
         "eval:\n"
         "  splits: [val_seen, val_unseen]\n"
         "  train_eval_episodes: 2\n"
         "  num_envs: 2\n"
         "  threads: 1\n"
         "  map_episodes: 0\n"
         "output:\n"
         "  dir: " +
         outDir.string() + "\n";
}

}  // namespace vln::train::test
