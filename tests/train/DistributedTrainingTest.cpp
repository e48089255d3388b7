// Multi-process runs of the `train` binary (src/train/DistributedTraining.cpp
// and the trainer's distributed paths) on the tiny world: two processes on
// loopback with RANK 0/1, WORLD_SIZE 2, MASTER_ADDR 127.0.0.1 and a free
// MASTER_PORT, as torchrun would start them.
//  - teacher forcing with batch 5 per rank against one process with batch
//    10 on the same 10 episodes, progress monitor on: the ranks end bitwise
//    identical, and equal to the one process up to float rounding (each
//    rank's losses are weighted by its share of the episodes and steps, so
//    the combined gradient is the 10-episode one); sharded evaluation
//    writes the eval binary's stats files, to the bit;
//  - an RxR split validated by two ranks: rank 0 writes the RxR inference
//    .jsonl of every instruction;
//  - DAgger, then --resume on both ranks for another iteration;
//  - the errors: missing variables, an unreachable master, different
//    configs, more ranks than episodes, --resume on one rank only, a resume
//    with another WORLD_SIZE.

#include <fcntl.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <set>
#include <thread>

#include "RxrTrainTestWorld.h"
#include "TinyWorldBinaryTest.h"
#include "TrainTestWorld.h"
#include "common/Json.h"
#include "data/RxrEpisodes.h"
#include "data/RxrPredictions.h"
#include "models/StateDict.h"
#include "rollout/Metrics.h"
#include "support/TestUtil.h"
#include "train/Checkpoint.h"
#include "train/FeatureStore.h"
#include "train/TensorBoardWriter.h"

extern char** environ;

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using vln::test::binary;
using vln::test::freePort;
using vln::test::readJsonLines;
using vln::test::readText;

// starts `train` with `args` and the environment of this process minus the
// torchrun variables, plus `env`; stdout and stderr go to `log`
pid_t launchTrain(const std::vector<std::string>& args,
                  const std::map<std::string, std::string>& env,
                  const fs::path& log) {
  static const std::set<std::string> cleared = {
      "RANK",        "WORLD_SIZE",  "LOCAL_RANK",
      "MASTER_ADDR", "MASTER_PORT", "VLN_DEBUG_PARAMETER_DUMP_DIR"};
  std::vector<std::string> envText;
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string entry = *e;
    const std::string key = entry.substr(0, entry.find('='));
    if (!cleared.count(key) && !env.count(key)) envText.push_back(entry);
  }
  for (const auto& [key, value] : env) envText.push_back(key + "=" + value);
  std::vector<char*> envp;
  for (auto& e : envText) envp.push_back(e.data());
  envp.push_back(nullptr);
  const std::string program = binary("train");
  std::vector<std::string> argText = {"train"};
  argText.insert(argText.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argText) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_CREAT | O_WRONLY | O_TRUNC, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    ::execve(program.c_str(), argv.data(), envp.data());
    ::_exit(127);
  }
  return pid;
}

// exit status of `pid`, or -1 after killing it when it runs past `seconds`
int waitExit(pid_t pid, int seconds) {
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::seconds(seconds);
  int status = 0;
  while (::waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

struct RankRun {
  int status = -1;
  std::string log;
};

class DistributedTrainingTest : public test::TinyWorldBinaryTest {
 protected:
  DistributedTrainingTest() : TinyWorldBinaryTest("train") {}

  fs::path writeConfig(const std::string& name, const std::string& trainer) {
    return vln::test::writeText(
        dir_ / (name + ".yaml"),
        test::tinyRunConfig(*world_, dir_ / name, trainer, "seq2seq"));
  }

  // both ranks of a WORLD_SIZE=2 run; rankArgs[r] are appended to `args`
  std::array<RankRun, 2> runTwoRanks(
      const std::vector<std::string>& args, const std::string& tag,
      const std::array<std::vector<std::string>, 2>& rankArgs = {},
      const std::map<std::string, std::string>& extraEnv = {}) {
    const int port = freePort();
    std::array<pid_t, 2> pids{};
    std::array<RankRun, 2> runs;
    for (int r = 0; r < 2; ++r) {
      std::map<std::string, std::string> env = extraEnv;
      env["RANK"] = std::to_string(r);
      env["LOCAL_RANK"] = std::to_string(r);
      env["WORLD_SIZE"] = "2";
      env["MASTER_ADDR"] = "127.0.0.1";
      env["MASTER_PORT"] = std::to_string(port);
      std::vector<std::string> all = args;
      all.insert(all.end(), rankArgs[static_cast<size_t>(r)].begin(),
                 rankArgs[static_cast<size_t>(r)].end());
      pids[static_cast<size_t>(r)] =
          launchTrain(all, env, dir_ / strCat(tag, ".rank", r, ".out"));
    }
    for (int r = 0; r < 2; ++r) {
      runs[static_cast<size_t>(r)].status =
          waitExit(pids[static_cast<size_t>(r)], 240);
      runs[static_cast<size_t>(r)].log =
          readText(dir_ / strCat(tag, ".rank", r, ".out"));
    }
    return runs;
  }

  RankRun runSingle(const std::vector<std::string>& args,
                    const std::map<std::string, std::string>& env,
                    const std::string& tag) {
    RankRun run;
    run.status = waitExit(launchTrain(args, env, dir_ / (tag + ".out")), 240);
    run.log = readText(dir_ / (tag + ".out"));
    return run;
  }
};

std::vector<torch::Tensor> tensorsOf(const models::NamedTensors& named) {
  std::vector<torch::Tensor> tensors;
  for (const auto& [name, t] : named) tensors.push_back(t.to(torch::kFloat64));
  return tensors;
}

double distance(const models::NamedTensors& a, const models::NamedTensors& b) {
  const auto ta = tensorsOf(a);
  const auto tb = tensorsOf(b);
  EXPECT_EQ(ta.size(), tb.size());
  double squares = 0.0;
  for (size_t i = 0; i < ta.size(); ++i)
    squares += (ta[i] - tb[i]).pow(2).sum().item<double>();
  return std::sqrt(squares);
}

bool bitwiseEqual(const models::NamedTensors& a,
                  const models::NamedTensors& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (a[i].first != b[i].first || !torch::equal(a[i].second, b[i].second))
      return false;
  return true;
}

TEST_F(DistributedTrainingTest, TwoRanksTrainLikeOneProcessOnTheWholeBatch) {
  // every update sees all 10 training episodes: batch 10 in one process,
  // 5 per rank in two
  const std::string trainer = "  epochs: 2\n  inflection_weight: 3.2\n";
  const fs::path singleConfig = writeConfig("single", trainer);
  const fs::path distConfig = writeConfig("dist", trainer);
  // TensorBoard media too (maps of 2 episodes by default, a video of 1):
  // rank 0 draws its own share's, which must not disturb the ranks' lockstep
  const std::vector<std::string> common = {
      "--set", "trainer.log_every_updates=1", "--set",
      "eval.tensorboard_videos=1"};
  auto args = [&](const fs::path& config, int batch) {
    std::vector<std::string> a = {
        "--config", config.string(), "--set",
        "trainer.batch_size=" + std::to_string(batch)};
    a.insert(a.end(), common.begin(), common.end());
    return a;
  };
  const RankRun single = runSingle(
      args(singleConfig, 10),
      {{"VLN_DEBUG_PARAMETER_DUMP_DIR", (dir_ / "dump1").string()}}, "single");
  ASSERT_EQ(single.status, 0) << single.log;
  const auto ranks = runTwoRanks(
      args(distConfig, 5), "dist", {},
      {{"VLN_DEBUG_PARAMETER_DUMP_DIR", (dir_ / "dump2").string()}});
  for (int r = 0; r < 2; ++r)
    ASSERT_EQ(ranks[static_cast<size_t>(r)].status, 0)
        << "rank " << r << ":\n"
        << ranks[static_cast<size_t>(r)].log;

  // the ranks' final weights are bitwise identical, and rank 0's checkpoint
  // holds them
  const fs::path run = dir_ / "dist";
  const auto rank0 = models::readTensorFile(dir_ / "dump2" / "rank0.pt");
  const auto rank1 = models::readTensorFile(dir_ / "dump2" / "rank1.pt");
  EXPECT_TRUE(bitwiseEqual(rank0, rank1));
  const auto distCkpts = listCheckpoints(run / "checkpoints");
  ASSERT_EQ(distCkpts.size(), 2u);
  EXPECT_TRUE(bitwiseEqual(loadCheckpoint(distCkpts.back()).policy, rank0));

  // equal to one process up to float rounding: the distance is tiny next to
  // what the second update moved the weights
  const auto singleCkpts = listCheckpoints(dir_ / "single" / "checkpoints");
  ASSERT_EQ(singleCkpts.size(), 2u);
  const auto singleEnd = loadCheckpoint(singleCkpts.back()).policy;
  const double step =
      distance(singleEnd, loadCheckpoint(singleCkpts[0]).policy);
  ASSERT_GT(step, 1e-3);
  EXPECT_LT(distance(rank0, singleEnd), 1e-3 * step);
  // the measured ratio, for docs/distributed.md (--gtest_output=json)
  RecordProperty("distance_over_last_step",
                 strCat(distance(rank0, singleEnd) / step));
  EXPECT_TRUE(bitwiseEqual(
      singleEnd, models::readTensorFile(dir_ / "dump1" / "rank0.pt")));

  // the logged losses and gradient norms of every update are the whole
  // batch's (means over the ranks), not rank 0's own
  auto updates = [](const fs::path& metrics) {
    std::vector<nlohmann::json> u;
    for (const auto& record : readJsonLines(metrics))
      if (record["type"] == "update") u.push_back(record);
    return u;
  };
  const auto singleUpdates = updates(dir_ / "single" / "metrics.jsonl");
  const auto distUpdates = updates(run / "metrics.jsonl");
  ASSERT_EQ(singleUpdates.size(), 2u);
  ASSERT_EQ(distUpdates.size(), 2u);
  for (size_t u = 0; u < 2; ++u) {
    const double loss = singleUpdates[u]["loss"].get<double>();
    const double norm = singleUpdates[u]["grad_norm"].get<double>();
    EXPECT_NEAR(distUpdates[u]["loss"].get<double>(), loss, 1e-4 * loss);
    const double progress = singleUpdates[u]["progress_loss"].get<double>();
    ASSERT_GT(progress, 0.0);
    EXPECT_NEAR(distUpdates[u]["progress_loss"].get<double>(), progress,
                1e-4 * progress);
    EXPECT_NEAR(distUpdates[u]["grad_norm"].get<double>(), norm, 1e-3 * norm);
    EXPECT_EQ(distUpdates[u]["steps"], singleUpdates[u]["steps"]);
  }

  // the shards: rank r collected the slots k with k % 2 == r, and together
  // they hold the one process's episodes
  auto single1 = FeatureStore::openExisting(dir_ / "single" / "store");
  std::array<std::unique_ptr<FeatureStore>, 2> shards = {
      FeatureStore::openExisting(run / "store" / "rank0"),
      FeatureStore::openExisting(run / "store" / "rank1")};
  std::map<int32_t, StoredEpisodeKey> byslot;
  for (int64_t i = 0; i < single1->size(); ++i)
    byslot[single1->key(i).slot] = single1->key(i);
  ASSERT_EQ(byslot.size(), 10u);
  for (int r = 0; r < 2; ++r) {
    const FeatureStore& shard = *shards[static_cast<size_t>(r)];
    EXPECT_EQ(shard.size(), 5);
    for (int64_t i = 0; i < shard.size(); ++i) {
      const StoredEpisodeKey& k = shard.key(i);
      EXPECT_EQ(k.slot % 2, r);
      EXPECT_EQ(k.episode_id, byslot[k.slot].episode_id);
      EXPECT_EQ(k.length, byslot[k.slot].length);
    }
  }

  // rank 0 alone wrote the run's files; each rank its log
  EXPECT_TRUE(fs::exists(run / "metrics.jsonl"));
  EXPECT_TRUE(fs::exists(run / "tb"));
  EXPECT_TRUE(fs::exists(run / "train.log"));
  EXPECT_THAT(readText(run / "train.rank1.log"), HasSubstr("[rank 1]"));
  EXPECT_EQ(common::readJsonFile(run / "distributed.json")["world_size"], 2);
  const auto finished = common::readJsonFile(run / "finished.json");
  EXPECT_EQ(finished["store_episodes"], 10);
  std::map<std::string, int> types;
  for (const auto& record : readJsonLines(run / "metrics.jsonl"))
    ++types[record["type"].get<std::string>()];
  EXPECT_EQ(types["collect"], 1);
  EXPECT_EQ(types["epoch"], 2);
  EXPECT_EQ(types["eval"], 4);
  for (const auto& record : readJsonLines(run / "metrics.jsonl"))
    if (record["type"] == "collect") {
      EXPECT_EQ(record["episodes"], 10);
    }
  // media: rank 0 ran episode 0 of each 2-episode split, so per evaluation
  // and split one map and one video, in rank 0's one event file
  EXPECT_EQ(types["eval_media"], 4);
  std::vector<fs::path> events;
  for (const auto& e : fs::directory_iterator(run / "tb")) events.push_back(e);
  ASSERT_EQ(events.size(), 1u);
  std::map<std::string, int> mediaTags;
  for (const TensorBoardImage& image : readTensorBoardFile(events[0]).images)
    ++mediaTags[image.tag.substr(0, image.tag.find("/episode_"))];
  EXPECT_EQ(mediaTags,
            (std::map<std::string, int>{{"eval/val_seen/map", 2},
                                        {"eval/val_seen/video", 2},
                                        {"eval/val_unseen/map", 2},
                                        {"eval/val_unseen/video", 2}}));

  // sharded evaluation (one episode per rank, gathered) = the eval binary
  // on the same checkpoint in one process, to the bit; each rank's summary
  // line counts its own share
  EXPECT_THAT(readText(run / "train.rank1.log"),
              HasSubstr("val_seen: 1 episodes (shard 1 of 2; the split has "
                        "2)"));
  std::string output;
  ASSERT_EQ(
      vln::test::runCommand(
          binary("eval") + " --log-level warn --config " + distConfig.string() +
              " --checkpoint " + distCkpts.back().string() +
              " --episodes 2 --out " + (dir_ / "evalcheck").string() + " 2>&1",
          &output),
      0)
      << output;
  for (const char* split : {"val_seen", "val_unseen"}) {
    const auto trainer =
        rollout::readStatsFile(run / "eval" / rollout::statsFileName(1, split));
    const auto alone = rollout::readStatsFile(dir_ / "evalcheck" /
                                              rollout::statsFileName(1, split));
    EXPECT_EQ(trainer.num_episodes, 2) << split;
    EXPECT_EQ(trainer, alone) << split;
    EXPECT_EQ(readText(run / "eval" / rollout::statsFileName(1, split)),
              readText(dir_ / "evalcheck" / rollout::statsFileName(1, split)))
        << split;
  }
}

TEST_F(DistributedTrainingTest, RxrValidationWritesTheJsonlOfEveryInstruction) {
  // an RxR split of 3 episodes validated by two ranks (2 + 1): rank 0
  // writes the RxR inference file of all 3 from the gathered episodes
  const test::TinyRxrWorld& w = test::tinyRxrWorld();
  const fs::path run = dir_ / "rxr";
  const fs::path config = vln::test::writeText(
      dir_ / "rxr.yaml", test::rxrRunConfig(w, run,
                                            "  dagger_iterations: 1\n"
                                            "  dagger_episodes: 6\n"
                                            "  dagger_epochs: 1\n"
                                            "  evaluate_every: iteration\n"));
  const auto ranks = runTwoRanks(
      {"--config", config.string(), "--set", "eval.train_eval_episodes=3"},
      "rxr");
  for (int r = 0; r < 2; ++r)
    ASSERT_EQ(ranks[static_cast<size_t>(r)].status, 0)
        << "rank " << r << ":\n"
        << ranks[static_cast<size_t>(r)].log;

  // the 3 validation episodes are the trainer's (evenly spaced guide
  // episodes of val_unseen); the file has one line per instruction, by id
  std::vector<data::Episode> episodes =
      data::readRxrEpisodes(w.data, "val_unseen", data::RxrFilterConfig{});
  data::keepEvenlySpaced(episodes, 3);
  std::vector<int64_t> ids;
  for (const data::Episode& e : episodes)
    ids.push_back(*e.instruction.instruction_id);
  std::sort(ids.begin(), ids.end());
  const auto lines = data::readRxrPredictions(
      run / "eval" / "rxr_predictions_ckpt_0_val_unseen.jsonl");
  std::vector<int64_t> written;
  for (const data::RxrPrediction& line : lines) {
    written.push_back(line.instruction_id);
    EXPECT_FALSE(line.path.empty());
  }
  EXPECT_EQ(written, ids);
  EXPECT_EQ(rollout::readStatsFile(run / "eval" /
                                   rollout::statsFileName(0, "val_unseen"))
                .num_episodes,
            3);
  EXPECT_THAT(readText(run / "train.rank1.log"),
              HasSubstr("val_unseen: 1 episodes (shard 1 of 2; the split has "
                        "3)"));
}

TEST_F(DistributedTrainingTest, DaggerResumesOnEveryRank) {
  const fs::path config = writeConfig(
      "run",
      "  dagger_iterations: 1\n  dagger_episodes: 4\n  dagger_epochs: 1\n"
      "  eval_during_training: false\n");
  const std::vector<std::string> args = {"--config", config.string()};
  const std::map<std::string, std::string> dump = {
      {"VLN_DEBUG_PARAMETER_DUMP_DIR", (dir_ / "dump").string()}};
  auto first = runTwoRanks(args, "first", {}, dump);
  for (int r = 0; r < 2; ++r)
    ASSERT_EQ(first[static_cast<size_t>(r)].status, 0)
        << first[static_cast<size_t>(r)].log;
  // one more iteration: each rank resumes its shard from rank 0's checkpoint
  auto second =
      runTwoRanks(args, "second",
                  {std::vector<std::string>{"--resume", "--set",
                                            "trainer.dagger_iterations=2"},
                   std::vector<std::string>{"--resume", "--set",
                                            "trainer.dagger_iterations=2"}},
                  dump);
  for (int r = 0; r < 2; ++r)
    ASSERT_EQ(second[static_cast<size_t>(r)].status, 0)
        << second[static_cast<size_t>(r)].log;
  const fs::path run = dir_ / "run";
  for (int r = 0; r < 2; ++r) {
    auto shard = FeatureStore::openExisting(run / "store" / strCat("rank", r));
    const std::set<int32_t> mine = {r, r + 2};
    EXPECT_EQ(shard->slots(0), mine) << "rank " << r;
    EXPECT_EQ(shard->slots(1), mine) << "rank " << r;
  }
  EXPECT_THAT(second[0].log, HasSubstr("resuming from"));
  EXPECT_THAT(second[1].log, HasSubstr("resuming from rank 0's checkpoint"));
  const auto checkpoints = listCheckpoints(run / "checkpoints");
  ASSERT_EQ(checkpoints.size(), 2u);
  const Checkpoint last = loadCheckpoint(checkpoints.back());
  EXPECT_EQ(last.progress.dagger_iteration, 2);
  EXPECT_EQ(last.progress.episodes_collected, 8);
  EXPECT_EQ(last.progress.extra["world_size"], 2);
  const auto rank0 = models::readTensorFile(dir_ / "dump" / "rank0.pt");
  EXPECT_TRUE(
      bitwiseEqual(rank0, models::readTensorFile(dir_ / "dump" / "rank1.pt")));
  EXPECT_TRUE(bitwiseEqual(rank0, last.policy));
  std::vector<int64_t> collected;
  for (const auto& record : readJsonLines(run / "metrics.jsonl"))
    if (record["type"] == "collect")
      collected.push_back(record["episodes"].get<int64_t>());
  EXPECT_EQ(collected, (std::vector<int64_t>{4, 4}));

  // one process cannot resume a two-process run
  const RankRun alone = runSingle({"--config", config.string(), "--resume",
                                   "--set", "trainer.dagger_iterations=2"},
                                  {}, "alone");
  EXPECT_NE(alone.status, 0);
  EXPECT_THAT(alone.log, HasSubstr("was trained by 2 process(es)"));
  EXPECT_THAT(alone.log, HasSubstr("resume it with WORLD_SIZE=2"));
}

TEST_F(DistributedTrainingTest, ErrorsNameTheVariableTheAddressAndTheKey) {
  const fs::path config =
      writeConfig("run", "  epochs: 1\n  eval_during_training: false\n");
  const std::vector<std::string> args = {"--config", config.string()};

  // a variable torchrun would have set is missing
  RankRun run = runSingle(args, {{"WORLD_SIZE", "2"}, {"RANK", "0"}}, "norank");
  EXPECT_NE(run.status, 0);
  EXPECT_THAT(run.log, HasSubstr("MASTER_ADDR is not set"));

  // rank 1 alone: the master never answers
  const int port = freePort();
  std::vector<std::string> quick = args;
  quick.insert(quick.end(), {"--set", "trainer.distributed_timeout_s=1"});
  run = runSingle(quick,
                  {{"WORLD_SIZE", "2"},
                   {"RANK", "1"},
                   {"MASTER_ADDR", "127.0.0.1"},
                   {"MASTER_PORT", std::to_string(port)}},
                  "nomaster");
  EXPECT_NE(run.status, 0);
  EXPECT_THAT(run.log, HasSubstr(strCat("rank 1 could not reach the master at "
                                        "MASTER_ADDR:MASTER_PORT = 127.0.0.1:",
                                        port, " within 1 s")));

  // the ranks disagree on the learning rate: both stop, naming it
  auto ranks =
      runTwoRanks(args, "mismatch",
                  {std::vector<std::string>{},
                   std::vector<std::string>{"--set", "trainer.lr=0.1"}});
  EXPECT_NE(ranks[0].status, 0);
  EXPECT_NE(ranks[1].status, 0);
  EXPECT_THAT(ranks[1].log,
              HasSubstr("trainer.lr: rank 0 has 0.002, rank 1 has 0.1"));
  EXPECT_THAT(ranks[0].log, HasSubstr("rank 1 failed during the config check"));
  EXPECT_THAT(ranks[0].log, HasSubstr("trainer.lr: rank 0 has 0.002"));
  EXPECT_FALSE(fs::exists(dir_ / "run"));

  // more ranks than episodes
  ranks = runTwoRanks(
      args, "small",
      {std::vector<std::string>{"--set", "dataset.max_train_episodes=1"},
       std::vector<std::string>{"--set", "dataset.max_train_episodes=1"}});
  for (int r = 0; r < 2; ++r) {
    EXPECT_NE(ranks[static_cast<size_t>(r)].status, 0);
    EXPECT_THAT(ranks[static_cast<size_t>(r)].log,
                HasSubstr("WORLD_SIZE = 2 is larger than the 1 episodes of a "
                          "collection round"));
  }

  // --resume given to one rank only
  ranks = runTwoRanks(
      args, "halfresume",
      {std::vector<std::string>{}, std::vector<std::string>{"--resume"}});
  for (int r = 0; r < 2; ++r) {
    EXPECT_NE(ranks[static_cast<size_t>(r)].status, 0);
    EXPECT_THAT(ranks[static_cast<size_t>(r)].log,
                HasSubstr("--resume was given to 1 of the 2 ranks"));
  }
}

}  // namespace
}  // namespace vln::train
