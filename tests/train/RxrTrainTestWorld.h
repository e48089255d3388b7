#pragma once
// The RxR split of configs/world/tiny.yaml's houses (RxR_VLNCE_v0 layout,
// guide and follower roles) with text features in RxR's .npz layout, made
// once per build tree (a file lock serialises the first generation), and
// the run config of a tiny CMA reading those features: shared by the RxR
// end-to-end test and the multi-process one.

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/Config.h"
#include "common/FileIo.h"
#include "data/RxrEpisodes.h"
#include "data/RxrTextFeatures.h"
#include "data/Vocabulary.h"
#include "support/TestPaths.h"
#include "train/TrainTestWorld.h"
#include "world/RxrWorldGenerator.h"

namespace vln::train::test {

namespace fs = std::filesystem;

inline constexpr int kFeatureDim = 16;

// Features of one instruction: a row per word of data::tokenize(), each a
// fixed function of the word (so equal words get equal rows, as a
// context-free encoder would give).
inline std::vector<float> fixtureFeatures(const std::string& text) {
  std::vector<float> values;
  for (const std::string& word : data::tokenize(text)) {
    const uint64_t h = std::hash<std::string>{}(word);
    for (int c = 0; c < kFeatureDim; ++c)
      values.push_back(static_cast<float>(
          std::sin(static_cast<double>((h >> (c % 48)) & 0xFFFF) * 1e-3 + c)));
  }
  if (values.empty()) values.assign(kFeatureDim, 0.0f);
  return values;
}

// The RxR split of the tiny world and its feature files, made once per
// build tree (a file lock serialises the first generation).
struct TinyRxrWorld {
  fs::path data;    ///< RxR_VLNCE-style root, text features under it
  fs::path scenes;  ///< sim.scenes_dir
};

inline const TinyRxrWorld& tinyRxrWorld() {
  static const TinyRxrWorld world = [] {
    const fs::path root =
        vln::test::binaryPath() / "tests" / "train_tiny_rxr_world";
    fs::create_directories(root);
    TinyRxrWorld w{root / "rxr", root / "scenes"};
    const int fd = ::open((root / "lock").c_str(), O_CREAT | O_RDWR, 0644);
    if (fd < 0) throw std::runtime_error("tinyRxrWorld(): no lock file");
    ::flock(fd, LOCK_EX);
    if (!fs::exists(root / "done")) {
      const fs::path configs = vln::test::sourcePath() / "configs" / "world";
      world::RxrWorldConfig config =
          common::loadConfigFile<world::RxrWorldConfig>(configs / "rxr.yaml");
      config.world =
          common::loadConfigFile<world::WorldConfig>(configs / "tiny.yaml");
      // RxrWorldGeneratorTest's quotas, which these houses meet
      config.splits.train_per_house = 8;
      config.splits.val_seen_per_house = 2;
      config.splits.val_unseen_per_house = 4;
      config.splits.test_challenge_per_house = 3;
      world::generateRxrWorld(config, {w.data, w.scenes, 2});
      data::RxrFilterConfig all;
      all.roles = {"*"};
      for (const char* split : {"train", "val_seen", "val_unseen"})
        for (const data::Episode& e : data::readRxrEpisodes(w.data, split, all))
          data::writeRxrTextFeatures(
              data::rxrTextFeaturesPath(w.data / "text_features", split,
                                        *e.instruction.instruction_id,
                                        e.instruction.language),
              fixtureFeatures(e.instruction.instruction_text), kFeatureDim);
      common::writeFileAtomic(root / "done", "ok\n");
    }
    ::flock(fd, LOCK_UN);
    ::close(fd);
    return w;
  }();
  return world;
}

// iteration 0 is teacher forcing (beta 1), iteration 1 lets the policy act
// (beta 0.75), reading the features while collecting
inline constexpr const char* kDaggerTrainer =
    "  dagger_iterations: 2\n"
    "  dagger_episodes: 6\n"
    "  dagger_epochs: 1\n"
    "  evaluate_every: iteration\n";

inline std::string rxrRunConfig(const TinyRxrWorld& w, const fs::path& out,
                                const std::string& trainer = kDaggerTrainer) {
  return "_base_: " +
         (vln::test::sourcePath() / "configs" / "rxr" / "task.yaml").string() +
         "\n" + tinySimYaml(w.scenes) +
         "task:\n"
         "  max_episode_steps: 150\n"
         "dataset:\n"
         "  format: rxr\n"
         "  data_path: " +
         w.data.string() +
         "\n"
         "  rxr_filter: {roles: [guide]}\n"
         "  max_instruction_length: 512\n"
         "model:\n"
         "  policy: cma\n"
         "  num_actions: 6\n"
         "  instruction_features: rxr_text\n"
         "  text_feature_dim: " +
         std::to_string(kFeatureDim) +
         "\n" + kTinyModelYaml + kTinyTrainerYaml + trainer +
         "eval:\n"
         "  splits: [val_unseen]\n"
         "  selection_split: val_unseen\n"
         "  train_eval_episodes: 2\n"
         "  num_envs: 2\n"
         "  threads: 1\n"
         "  map_episodes: 0\n"
         "output:\n"
         "  dir: " +
         out.string() +
         "\n"
         "  tensorboard: false\n";
}

}  // namespace vln::train::test
