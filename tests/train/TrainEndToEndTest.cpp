// End-to-end runs of the `train` and `vlnce-export` binaries on the tiny
// procedural world: teacher forcing, DAgger, kill -9 during collection and
// --resume, the run-directory rules, the TensorBoard media of the
// periodic evaluation (maps and videos read back from the event file), and
// that training never reads the test split's hidden goals.

#include <fcntl.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <thread>

#include <torch/script.h>

#include "TinyWorldBinaryTest.h"
#include "TrainTestWorld.h"
#include "common/Json.h"
#include "data/Episode.h"
#include "data/Split.h"
#include "rollout/Metrics.h"
#include "support/GifDecoder.h"
#include "support/TestUtil.h"
#include "train/Checkpoint.h"
#include "train/FeatureStore.h"
#include "train/TensorBoardWriter.h"
#include "viz/Image.h"

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using vln::test::binary;
using vln::test::readJsonLines;

std::string trainCommand(const fs::path& config,
                         const std::string& extra = "") {
  return binary("train") + " --config " + config.string() + " " + extra +
         " 2>&1";
}

std::vector<fs::path> eventFiles(const fs::path& dir) {
  std::vector<fs::path> files;
  if (!fs::exists(dir)) return files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().starts_with("events.out.tfevents."))
      files.push_back(e.path());
  return files;
}

class TrainEndToEndTest : public test::TinyWorldBinaryTest {
 protected:
  TrainEndToEndTest() : TinyWorldBinaryTest("train") {}
  // `output` is appended to the last section (output:)
  fs::path writeConfig(const std::string& trainer,
                       const std::string& policy = "cma",
                       const std::string& output = "") {
    return vln::test::writeText(
        dir_ / "config.yaml",
        test::tinyRunConfig(*world_, dir_ / "run", trainer, policy) + output);
  }
};

TEST_F(TrainEndToEndTest, TeacherForcingRunProducesEverything) {
  const fs::path config =
      writeConfig("  epochs: 2\n  use_aug: true\n  inflection_weight: 0\n",
                  "seq2seq", "  keep_checkpoints: 1\n");
  std::string output;
  ASSERT_EQ(vln::test::runCommand(trainCommand(config, "--dry-run"), &output),
            0)
      << output;
  EXPECT_THAT(output, HasSubstr("epochs: 2"));
  EXPECT_FALSE(fs::exists(dir_ / "run"));

  ASSERT_EQ(
      vln::test::runCommand(
          trainCommand(config, "--export " + (dir_ / "policy.pt").string()),
          &output),
      0)
      << output;
  const fs::path run = dir_ / "run";
  EXPECT_TRUE(fs::exists(run / "config.yaml"));
  EXPECT_TRUE(fs::exists(run / "train.log"));
  const auto checkpoints = listCheckpoints(run / "checkpoints");
  ASSERT_FALSE(checkpoints.empty());
  EXPECT_EQ(checkpointIndex(checkpoints.back()), 1);
  const Checkpoint last = loadCheckpoint(checkpoints.back());
  EXPECT_EQ(last.progress.epoch, 2);
  EXPECT_EQ(last.progress.stage, "teacher_forcing");
  EXPECT_GT(last.progress.updates, 0);

  // the store holds every train episode plus every aug episode, once
  const auto train =
      data::readEpisodes(data::splitEpisodesPath(world_->data, "train"));
  const auto aug =
      data::readEpisodes(data::splitEpisodesPath(world_->data, "train_aug"));
  auto store = FeatureStore::openExisting(run / "store");
  EXPECT_EQ(store->size(),
            static_cast<int64_t>(train.episodes.size() + aug.episodes.size()));

  // metrics: collection with the ground-truth agreement, updates, epochs, evals
  std::map<std::string, int> types;
  double inflection = 0;
  for (const auto& record : readJsonLines(run / "metrics.jsonl")) {
    ++types[record["type"].get<std::string>()];
    if (record["type"] == "epoch")
      inflection = record["inflection_coef"].get<double>();
    if (record["type"] == "collect") {
      EXPECT_GT(record["store_bytes_per_step"].get<double>(), 0.0);
      EXPECT_EQ(record["gt_episodes"].get<int64_t>(),
                static_cast<int64_t>(train.episodes.size()));
    }
  }
  EXPECT_EQ(types["collect"], 1);
  EXPECT_EQ(types["epoch"], 2);
  EXPECT_GE(types["update"], 1);
  EXPECT_EQ(types["eval"], 4);  // two splits after each of two epochs
  EXPECT_GT(inflection, 1.0);  // auto coefficient: inverse inflection frequency

  // TensorBoard: one file, valid CRCs, training and eval scalars
  const auto events = eventFiles(run / "tb");
  ASSERT_EQ(events.size(), 1u);
  const TensorBoardFile tb = readTensorBoardFile(events[0]);
  std::set<std::string> tags;
  for (const auto& s : tb.scalars) tags.insert(s.tag);
  EXPECT_TRUE(tags.count("train/loss"));
  EXPECT_TRUE(tags.count("epoch/loss"));
  EXPECT_TRUE(tags.count("eval/val_unseen/spl"));

  // eval stats files and the best checkpoint, which keep_checkpoints keeps
  for (int i : {0, 1})
    for (const char* split : {"val_seen", "val_unseen"})
      EXPECT_EQ(rollout::readStatsFile(run / "eval" /
                                       rollout::statsFileName(i, split))
                    .num_episodes,
                2);
  const auto best = common::readJsonFile(run / "checkpoints" / "best.json");
  EXPECT_TRUE(
      fs::exists(run / "checkpoints" / best["checkpoint"].get<std::string>()));
  EXPECT_LE(checkpoints.size(), 2u);
  EXPECT_TRUE(fs::exists(run / "finished.json"));

  // the export loads as TorchScript and runs one step
  torch::jit::Module module = torch::jit::load((dir_ / "policy.pt").string());
  const int64_t layers = 1, hidden = 16;
  auto out = module
                 .forward({torch::zeros({1, 32, 32, 3}, torch::kUInt8),
                           torch::zeros({1, 32, 32, 1}),
                           torch::ones({1, 3}, torch::kInt64),
                           torch::zeros({1}, torch::kInt64), torch::zeros({1}),
                           torch::zeros({1, layers, hidden})})
                 .toTuple();
  EXPECT_EQ(out->elements()[0].toTensor().sizes(),
            (std::vector<int64_t>{1, 4}));

  // vlnce-export from a checkpoint with its embedded config
  ASSERT_EQ(vln::test::runCommand(binary("vlnce-export") + " --checkpoint " +
                                      checkpoints.back().string() + " --out " +
                                      (dir_ / "again.pt").string() + " 2>&1",
                                  &output),
            0)
      << output;
  EXPECT_TRUE(fs::exists(dir_ / "again.pt"));

  // a fresh run in the non-empty directory is refused
  EXPECT_NE(vln::test::runCommand(trainCommand(config), &output), 0);
  EXPECT_THAT(output, HasSubstr("--resume"));
  // resuming the finished run trains nothing more and can export again
  ASSERT_EQ(vln::test::runCommand(
                trainCommand(config, "--resume --export " +
                                         (dir_ / "third.pt").string()),
                &output),
            0)
      << output;
  EXPECT_EQ(listCheckpoints(run / "checkpoints").back(), checkpoints.back());
  EXPECT_TRUE(fs::exists(dir_ / "third.pt"));
  // a changed learning rate is refused with the key named
  EXPECT_NE(vln::test::runCommand(
                trainCommand(config, "--resume --set trainer.lr=0.1"), &output),
            0);
  EXPECT_THAT(output, HasSubstr("trainer.lr"));
}

TEST_F(TrainEndToEndTest, DaggerRunAggregatesRounds) {
  const fs::path config = writeConfig(
      "  dagger_iterations: 2\n  dagger_episodes: 4\n  dagger_epochs: 1\n"
      "  eval_during_training: false\n");
  std::string output;
  // with the instruction-contrast loss on, which every epoch reports, the
  // learning rate halved per iteration, and the CMA counting its turns
  // (collected with the count in the recurrent state's third row)
  ASSERT_EQ(vln::test::runCommand(
                trainCommand(config,
                             "--set trainer.instruction_contrast_weight=0.5 "
                             "--set trainer.lr_decay=0.5 "
                             "--set model.turn_count_embedding_dim=4"),
                &output),
            0)
      << output;
  const fs::path run = dir_ / "run";
  auto store = FeatureStore::openExisting(run / "store");
  ASSERT_EQ(store->size(), 8);
  EXPECT_EQ(store->slots(0), (std::set<int32_t>{0, 1, 2, 3}));
  EXPECT_EQ(store->slots(1), (std::set<int32_t>{0, 1, 2, 3}));
  const auto checkpoints = listCheckpoints(run / "checkpoints");
  ASSERT_EQ(checkpoints.size(), 2u);
  const Checkpoint last = loadCheckpoint(checkpoints.back());
  EXPECT_EQ(last.progress.dagger_iteration, 2);
  EXPECT_EQ(last.progress.stage, "dagger");
  EXPECT_EQ(last.progress.episodes_collected, 8);
  bool countsTurns = false;
  for (const auto& [name, tensor] : last.policy)
    if (name == "turn_count_embedding.weight")
      countsTurns = tensor.sizes() == torch::IntArrayRef{25, 4};
  EXPECT_TRUE(countsTurns);
  std::vector<double> betas, rates;
  int epochs = 0;
  for (const auto& record : readJsonLines(run / "metrics.jsonl")) {
    if (record["type"] == "collect")
      betas.push_back(record["beta"].get<double>());
    if (record["type"] == "epoch") {
      ++epochs;
      rates.push_back(record["lr"].get<double>());
      // batches of different instructions: positive, finite
      EXPECT_GT(record["instruction_contrast"].get<double>(), 0.0);
      EXPECT_LT(record["instruction_contrast"].get<double>(), 10.0);
    }
  }
  EXPECT_EQ(betas, (std::vector<double>{1.0, 0.75}));
  EXPECT_EQ(epochs, 2);
  ASSERT_EQ(rates.size(), 2u);
  EXPECT_GT(rates[0], 0.0);
  EXPECT_DOUBLE_EQ(rates[1], rates[0] * 0.5);
  EXPECT_FALSE(fs::exists(run / "eval"));
}

// eval.tensorboard_maps = 2 and eval.tensorboard_videos = 1: after the one
// epoch's evaluation, the event file holds, per split, the maps of its
// first two episodes (PNG) and the video of its first (GIF, a frame per
// position) at step 0, the checkpoint, and metrics.jsonl lists them.
// Prints the sizes of the maps and videos.
TEST_F(TrainEndToEndTest, TensorBoardMapsAndVideosOfThePeriodicEvaluation) {
  const fs::path config = writeConfig("  epochs: 1\n", "seq2seq");
  std::string output;
  ASSERT_EQ(
      vln::test::runCommand(trainCommand(config,
                                         "--set eval.tensorboard_maps=2 --set "
                                         "eval.tensorboard_videos=1"),
                            &output),
      0)
      << output;
  const fs::path run = dir_ / "run";
  const auto events = eventFiles(run / "tb");
  ASSERT_EQ(events.size(), 1u);
  const TensorBoardFile tb = readTensorBoardFile(events[0]);  // checks CRCs
  std::map<std::string, const TensorBoardImage*> images;
  for (const TensorBoardImage& image : tb.images) images[image.tag] = &image;
  EXPECT_EQ(tb.images.size(), 6u);  // 2 maps + 1 video, two splits

  std::map<std::string, nlohmann::json> listed;  // eval_media, by tag
  for (const auto& record : readJsonLines(run / "metrics.jsonl"))
    if (record["type"] == "eval_media") {
      EXPECT_EQ(record["checkpoint"], 0);
      for (const auto& item : record["media"])
        listed[item["tag"].get<std::string>()] = item;
    }
  EXPECT_EQ(listed.size(), 6u);

  for (const std::string split : {"val_seen", "val_unseen"}) {
    SCOPED_TRACE(split);
    // the periodic evaluation's episodes: two, spread over the split
    const data::Split episodes = data::loadSplit(world_->data, split, 2);
    ASSERT_EQ(episodes.episodes.size(), 2u);
    for (int i = 0; i < 2; ++i) {
      const std::string id =
          std::to_string(episodes.episodes[static_cast<size_t>(i)].episode_id);
      const std::string mapTag = "eval/" + split + "/map/episode_" + id;
      ASSERT_TRUE(images.count(mapTag)) << mapTag;
      const TensorBoardImage& map = *images[mapTag];
      EXPECT_EQ(map.step, 0);
      EXPECT_EQ(map.colorspace, 3);
      const viz::Image png = viz::decodePng(map.encoded);
      EXPECT_EQ(png.width, map.width);
      EXPECT_EQ(png.height, map.height);
      EXPECT_EQ(listed[mapTag]["bytes"].get<size_t>(), map.encoded.size());
      const std::string videoTag = "eval/" + split + "/video/episode_" + id;
      if (i == 1) {
        EXPECT_FALSE(images.count(videoTag)) << videoTag;
        continue;
      }
      ASSERT_TRUE(images.count(videoTag)) << videoTag;
      const TensorBoardImage& video = *images[videoTag];
      EXPECT_EQ(video.step, 0);
      EXPECT_EQ(video.colorspace, 3);
      const vln::test::DecodedGif gif = vln::test::decodeGif(video.encoded);
      EXPECT_EQ(gif.width, video.width);
      EXPECT_EQ(gif.height, video.height);
      // a frame after reset and after each action, up to the 120-step limit
      EXPECT_GE(gif.frames.size(), 2u);
      EXPECT_LE(gif.frames.size(), 121u);
      EXPECT_EQ(listed[videoTag]["frames"].get<size_t>(), gif.frames.size());
      std::cout << split << ": map PNG " << map.width << "x" << map.height
                << " " << map.encoded.size() << " bytes; video GIF "
                << video.width << "x" << video.height << ", "
                << gif.frames.size() << " frames, " << video.encoded.size()
                << " bytes\n";
    }
  }
}

// The test split's hidden goals (<data>/hidden/, the local leaderboard of
// the eval binary) are never read by the trainer: a teacher-forcing run
// with validation on a dataset that has them, traced with strace (every
// file system call of every thread), touches no path under hidden/; the
// folder is also made unreadable, which stops a reader that is not root.
// Skipped as root without strace (permissions do not stop root).
TEST_F(TrainEndToEndTest, NeverReadsTheHiddenTestGoals) {
  const bool haveStrace = vln::test::runCommand("strace -V") == 0;
  if (!haveStrace && ::geteuid() == 0)
    GTEST_SKIP() << "root ignores permissions and strace is absent";
  // the tiny world with a hidden folder holding val_unseen as test goals
  const fs::path data = dir_ / "data";
  fs::create_directories(data);
  const fs::path hidden = data / "hidden";
  for (const auto& entry : fs::directory_iterator(world_->data))
    if (entry.path().filename() != "hidden")  // shared: ours is below
      fs::create_symlink(entry.path(), data / entry.path().filename());
  fs::create_directories(hidden / "test");
  fs::copy_file(data::splitEpisodesPath(world_->data, "val_unseen"),
                hidden / "test" / "test_goals.json.gz");
  fs::copy_file(data::splitGroundTruthPath(world_->data, "val_unseen"),
                hidden / "test" / "test_gt.json.gz");
  fs::permissions(hidden, fs::perms::none);

  const fs::path config = writeConfig("  epochs: 1\n");
  const fs::path trace = dir_ / "strace.txt";
  const std::string command =
      (haveStrace ? "strace -f -qq -e trace=%file -o " + trace.string() + " "
                  : std::string()) +
      trainCommand(config, "--set dataset.data_path=" + data.string());
  std::string output;
  const int status = vln::test::runCommand(command, &output);
  fs::permissions(hidden, fs::perms::owner_all);  // so TempDir can remove it
  ASSERT_EQ(status, 0) << output;
  EXPECT_TRUE(fs::exists(dir_ / "run" / "eval" /
                         rollout::statsFileName(0, "val_unseen")));
  if (!haveStrace) return;
  const std::string calls = vln::test::readText(trace);
  EXPECT_THAT(calls,
              HasSubstr(data::splitEpisodesPath(data, "train").string()));
  EXPECT_THAT(calls, ::testing::Not(HasSubstr(hidden.string())));
}

// SIGKILL while round 1 is being collected, then --resume: the store ends
// with exactly every slot of both rounds, once.
TEST_F(TrainEndToEndTest, KillDuringCollectionThenResume) {
  const fs::path config = writeConfig(
      "  dagger_iterations: 2\n  dagger_episodes: 12\n  dagger_epochs: 1\n"
      "  use_aug: true\n  eval_during_training: false\n");
  const fs::path run = dir_ / "run";
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const int fd = ::open((dir_ / "first.log").c_str(),
                          O_CREAT | O_WRONLY | O_TRUNC, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    const std::string train = binary("train");
    ::execl(train.c_str(), "train", "--config", config.c_str(),
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // wait until round 1 has stored a few episodes, then kill -9 the trainer
  bool killed = false;
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (!fs::exists(run / "store" / "data.mdb")) continue;
    int64_t round1 = 0;
    try {
      round1 = static_cast<int64_t>(
          FeatureStore::openExisting(run / "store")->slots(1).size());
    } catch (const std::exception&) {
      continue;  // the meta record is not there yet
    }
    if (round1 >= 2) {
      ::kill(child, SIGKILL);
      killed = true;
      break;
    }
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(killed) << "the run finished or stalled before round 1";
  const int64_t before = FeatureStore::openExisting(run / "store")->size();
  EXPECT_LT(before, 24);

  std::string output;
  ASSERT_EQ(vln::test::runCommand(trainCommand(config, "--resume"), &output), 0)
      << output;
  auto store = FeatureStore::openExisting(run / "store");
  ASSERT_EQ(store->size(), 24);
  std::set<int32_t> all;
  for (int k = 0; k < 12; ++k) all.insert(k);
  EXPECT_EQ(store->slots(0), all);
  EXPECT_EQ(store->slots(1), all);
  EXPECT_EQ(loadCheckpoint(listCheckpoints(run / "checkpoints").back())
                .progress.dagger_iteration,
            2);
  EXPECT_THAT(output, ::testing::Not(HasSubstr("error")));
}

}  // namespace
}  // namespace vln::train
