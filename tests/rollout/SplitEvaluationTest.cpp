// evaluateSplit(): the files it writes. An agent replaying the ground truth
// of the shared test house gives paths known in advance, so the RxR
// inference file (.jsonl) of a split of RxR episodes can be checked line by
// line; an R2R split writes none.

#include "rollout/SplitEvaluation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>

#include "common/Json.h"
#include "data/RxrPredictions.h"
#include "rollout/RolloutTestWorld.h"

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

SplitEvaluation evaluate(const data::Split& split, const fs::path& out) {
  const auto& w = rolloutTestWorld();
  ReplayAgent agent(w.groundTruth);
  EvalConfig eval;
  eval.num_envs = 3;
  eval.threads = 2;
  SplitEvaluationOptions options;
  options.checkpoint = 4;
  options.out_dir = out;
  return evaluateSplit(agent, split, std::make_shared<SceneCache>(w.sim), w.sim,
                       w.task, eval, options);
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

}  // namespace
}  // namespace vln::rollout
