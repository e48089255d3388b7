// evaluateSplit(): the files it writes. An agent replaying the ground truth
// of the shared test house gives paths known in advance, so the RxR
// inference file (.jsonl) of a split of RxR episodes can be checked line by
// line; an R2R split writes none. A multi-process evaluation is simulated
// by shards on threads whose gather exchanges their bytes: its files equal
// one process's byte for byte, and gathered bytes that do not fit the split
// are errors.

#include "rollout/SplitEvaluation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <future>
#include <map>
#include <thread>

#include "common/Json.h"
#include "data/RxrPredictions.h"
#include "rollout/RolloutTestWorld.h"
#include "support/TestUtil.h"

namespace vln::rollout {
namespace {

namespace fs = std::filesystem;
using test::rolloutTestWorld;

// Replays each episode's ground-truth actions.
class ReplayAgent : public Agent {
 public:
  explicit ReplayAgent(const data::GroundTruth& gt) : gt_(gt) {}
  void reset(int env, const data::Episode& episode) override {
    cursor_[env] = {episode.episode_id, 0};
  }
  std::vector<sim::Action> act(VectorEnv&,
                               std::span<const int> active) override {
    std::vector<sim::Action> actions;
    for (int env : active) {
      auto& [id, step] = cursor_.at(env);
      actions.push_back(gt_.at(id).actions.at(static_cast<size_t>(step++)));
    }
    return actions;
  }
  bool needsObservations() const override { return false; }

 private:
  const data::GroundTruth& gt_;
  std::map<int, std::pair<int, int>> cursor_;
};

// The test world's episodes as a split; RxR instruction ids when `rxr`
// (in reverse episode order, so the file's sorting shows)
data::Split splitOf(bool rxr) {
  const auto& w = rolloutTestWorld();
  data::Split split;
  split.name = "val_unseen";
  split.episodes = w.episodes;
  split.hasGoals = true;
  split.groundTruth = std::make_unique<data::GroundTruth>(w.groundTruth);
  if (rxr)
    for (size_t i = 0; i < split.episodes.size(); ++i) {
      split.episodes[i].instruction.instruction_id =
          static_cast<int64_t>(1000 - i);
      split.episodes[i].instruction.language = "en-US";
    }
  return split;
}

// Evaluates `split` as checkpoint 4 into `out` with `options`' shard,
// num_shards, gather and file switches.
SplitEvaluation evaluate(const data::Split& split, const fs::path& out,
                         SplitEvaluationOptions options = {}) {
  const auto& w = rolloutTestWorld();
  ReplayAgent agent(w.groundTruth);
  EvalConfig eval;
  eval.num_envs = 3;
  eval.threads = 2;
  options.checkpoint = 4;
  options.out_dir = out;
  return evaluateSplit(agent, split, std::make_shared<SceneCache>(w.sim), w.sim,
                       w.task, eval, options);
}

// `split` evaluated as `n` processes would: shard s on thread s, the gather
// an exchange of the shards' bytes; shard 0 writes into `out` with
// `options`' file switches. Returns every shard's evaluation; a shard's
// exception reaches the others through the exchange and is rethrown.
std::vector<SplitEvaluation> evaluateAsShards(const data::Split& split,
                                              const fs::path& out, int n,
                                              SplitEvaluationOptions options) {
  std::vector<std::promise<std::string>> sent(static_cast<size_t>(n));
  std::vector<std::shared_future<std::string>> received;
  for (auto& p : sent) received.push_back(p.get_future().share());
  std::vector<SplitEvaluation> results(static_cast<size_t>(n));
  std::vector<std::exception_ptr> errors(static_cast<size_t>(n));
  std::vector<std::thread> threads;
  for (int s = 0; s < n; ++s)
    threads.emplace_back([&, s] {
      const auto self = static_cast<size_t>(s);
      SplitEvaluationOptions o = options;
      o.shard = s;
      o.num_shards = n;
      o.gather = [&, self](const std::string& mine) {
        sent[self].set_value(mine);
        std::vector<std::string> all;
        for (const auto& f : received) all.push_back(f.get());
        return all;
      };
      try {
        results[self] = evaluate(split, s == 0 ? out : fs::path(), o);
      } catch (...) {
        errors[self] = std::current_exception();
        try {
          sent[self].set_exception(errors[self]);  // unblock the others
        } catch (const std::future_error&) {
          // it failed after sending its bytes
        }
      }
    });
  for (auto& t : threads) t.join();
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
  return results;
}

// file name -> bytes of every file in `dir`
std::map<std::string, std::string> filesIn(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::directory_iterator(dir))
    files[entry.path().filename().string()] = vln::test::readText(entry.path());
  return files;
}

TEST(SplitEvaluationTest, RxrSplitWritesTheInferenceFileOfEveryInstruction) {
  vln::test::TempDir dir;
  const data::Split split = splitOf(/*rxr=*/true);
  const SplitEvaluation r = evaluate(split, dir.path());
  const fs::path file = dir.path() / "rxr_predictions_ckpt_4_val_unseen.jsonl";
  ASSERT_TRUE(fs::exists(file));
  EXPECT_THAT(r.files, ::testing::Contains(file));

  // one line per instruction, sorted by id: the follower's positions
  // without consecutive repeats
  const auto& w = rolloutTestWorld();
  const std::vector<data::RxrPrediction> lines = data::readRxrPredictions(file);
  ASSERT_EQ(lines.size(), split.episodes.size());
  for (size_t k = 0; k < lines.size(); ++k) {
    const size_t i = split.episodes.size() - 1 - k;  // ids run backwards
    SCOPED_TRACE(k);
    EXPECT_EQ(lines[k].instruction_id, static_cast<int64_t>(1000 - i));
    EXPECT_EQ(lines[k].path,
              data::rxrPathFromPositions(w.followerPositions[i]));
    EXPECT_EQ(lines[k].path.front(), w.followerPositions[i].front());
  }

  // RxR's metrics are in the stats beside it
  const nlohmann::json stats =
      common::readJsonFile(dir.path() / statsFileName(4, "val_unseen"));
  EXPECT_TRUE(stats.contains("ndtw"));
  EXPECT_TRUE(stats.contains("sdtw"));
  EXPECT_GT(stats["ndtw"].get<double>(), 0.5);  // replayed ground truth
}

TEST(SplitEvaluationTest, R2rSplitWritesNoRxrFile) {
  vln::test::TempDir dir;
  evaluate(splitOf(/*rxr=*/false), dir.path());
  EXPECT_TRUE(fs::exists(dir.path() / statsFileName(4, "val_unseen")));
  EXPECT_FALSE(
      fs::exists(dir.path() / "rxr_predictions_ckpt_4_val_unseen.jsonl"));
}

TEST(SplitEvaluationTest, ShardsGatheredWriteTheFilesOfOneProcess) {
  for (const bool rxr : {false, true}) {
    // two episodes without goals (no metrics, leaderboard entries), in
    // different shards of 2 and of 3
    data::Split split = splitOf(rxr);
    for (size_t i : {3, 4}) split.episodes[i].goals.clear();
    SplitEvaluationOptions files;
    files.save_episodes = true;
    files.predictions_of_scored = true;
    vln::test::TempDir one;
    const SplitEvaluation alone = evaluate(split, one.path(), files);
    const auto expected = filesIn(one.path());
    // stats, episodes, leaderboard predictions, and for RxR the .jsonl
    ASSERT_EQ(expected.size(), rxr ? 4u : 3u);
    EXPECT_EQ(alone.stats.num_episodes, 8);

    // 2 shards of 5 episodes, 3 shards of 4, 3 and 3
    for (const int n : {2, 3}) {
      SCOPED_TRACE(strCat(rxr ? "RxR" : "R2R", ", ", n, " shards"));
      vln::test::TempDir dir;
      const std::vector<SplitEvaluation> shards =
          evaluateAsShards(split, dir.path(), n, files);
      EXPECT_EQ(filesIn(dir.path()), expected);
      for (int s = 0; s < n; ++s) {
        const SplitEvaluation& e = shards[static_cast<size_t>(s)];
        // every shard holds the whole split, with one process's stats bits
        EXPECT_EQ(e.stats, alone.stats);
        EXPECT_EQ(e.result.scored, alone.result.scored);
        ASSERT_EQ(e.result.episodes.size(), split.episodes.size());
        for (size_t i = 0; i < split.episodes.size(); ++i) {
          EXPECT_EQ(e.result.episodes[i].record.episode_id,
                    std::to_string(split.episodes[i].episode_id));
          EXPECT_EQ(e.result.episodes[i].record.positions,
                    alone.result.episodes[i].record.positions);
          EXPECT_EQ(e.result.episodes[i].metrics,
                    alone.result.episodes[i].metrics);
        }
        // its counts are its own share's, and the summary says so
        EXPECT_EQ(e.episodes, (10 - s + n - 1) / n);
        EXPECT_THAT(summaryLine(e), ::testing::HasSubstr(strCat(
                                        e.episodes, " episodes (shard ", s,
                                        " of ", n, "; the split has 10)")));
        EXPECT_EQ(e.files.empty(), s != 0);
      }
      if (rxr) {
        EXPECT_EQ(data::readRxrPredictions(
                      dir.path() / rxrPredictionsFileName(4, "val_unseen"))
                      .size(),
                  split.episodes.size());
      }
    }
  }
}

TEST(SplitEvaluationTest, GatheredBytesThatDoNotFitTheSplitAreErrors) {
  const data::Split split = splitOf(/*rxr=*/false);
  auto gatherReturning = [](int wrong) -> GatherOverProcesses {
    return [wrong](const std::string& mine) {
      // 0: shard 0's bytes again as shard 1's; 1: not CBOR; 2: one shard
      if (wrong == 0) return std::vector<std::string>{mine, mine};
      if (wrong == 1) return std::vector<std::string>{mine, "not cbor"};
      return std::vector<std::string>{mine};
    };
  };
  const std::array<std::string, 3> messages = {
      "split 'val_unseen': the episodes of shard 1 of 2: entry 0 is "
      "episode '" +
          std::to_string(split.episodes[0].episode_id) +
          "', expected the split's episode 1",
      "the episodes of shard 1 of 2 are not readable",
      "split 'val_unseen': the gather returned 1 shards' episodes, "
      "expected 2"};
  for (int wrong = 0; wrong < 3; ++wrong) {
    SplitEvaluationOptions options;
    options.num_shards = 2;
    options.gather = gatherReturning(wrong);
    EXPECT_THAT(
        [&] { evaluate(split, fs::path(), options); },
        ::testing::ThrowsMessage<std::runtime_error>(
            ::testing::HasSubstr(messages[static_cast<size_t>(wrong)])));
  }
  // two shards need a gather
  SplitEvaluationOptions none;
  none.num_shards = 2;
  EXPECT_THAT([&] { evaluate(split, fs::path(), none); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  ::testing::HasSubstr("2 shards need a gather")));
}

}  // namespace
}  // namespace vln::rollout
