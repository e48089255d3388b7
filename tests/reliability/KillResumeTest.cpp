// kill -9 at random moments, then `train --resume`, until the run finishes.
//
// A reference run (never killed) and a killed run share one config and
// seed. The killed run is SIGKILLed $VLN_KILL_COUNT times (default 10), each
// time by one of three triggers, in turn:
//   random      after a uniform delay in [0.2 s, reference duration / 3];
//   checkpoint  the moment a checkpoint temporary file (ckpt.*.tmp.*)
//               appears, i.e. during a checkpoint write;
//   store       right after (0-3 ms) data.mdb changes, i.e. around a
//               feature-store commit.
// After every kill: every checkpoint file loads, the store opens and every
// episode passes its CRC check, no (round, slot) is stored twice, every
// stored episode is the one (id and source) the reference run stored in
// that (round, slot),
// and no checkpoint claims more episodes than the store holds. At the end:
// the run completes, its store holds exactly the reference run's episodes
// and its checkpoints are the reference run's indices, no temporary file is
// left, and the final weights and Adam state equal the reference run's bit
// for bit (trainer.exact_resume). The random stream is
// $VLN_KILL_SEED (default 1); scripts/kill_test.sh passes a fresh one.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <optional>
#include <random>
#include <thread>
#include <tuple>

#include "ReliabilityWorld.h"
#include "train/Checkpoint.h"
#include "train/FeatureStore.h"

namespace vln::reliability {
namespace {

using Clock = std::chrono::steady_clock;

int envInt(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::atoi(v) : fallback;
}

// (round, slot) -> (episode id, source, length)
using StoreKeys = std::map<std::pair<int32_t, int32_t>, std::tuple<int64_t, int, int32_t>>;

// the store's keys; fails the test on a duplicate or an unreadable episode
StoreKeys storeKeys(const fs::path& dir) {
  StoreKeys keys;
  auto store = train::FeatureStore::openExisting(dir);
  for (int64_t i = 0; i < store->size(); ++i) {
    const train::StoredEpisode e = store->read(i);  // checks the CRC
    const auto where = std::make_pair(e.key.iteration, e.key.slot);
    EXPECT_FALSE(keys.count(where)) << "round " << where.first << " slot " << where.second
                                    << " stored twice";
    keys[where] = {e.key.episode_id, e.key.source, static_cast<int32_t>(e.length())};
  }
  return keys;
}

// (round, slot) -> (episode id, source): what must not be lost or doubled
std::map<std::pair<int32_t, int32_t>, std::pair<int64_t, int>> ids(const StoreKeys& keys) {
  std::map<std::pair<int32_t, int32_t>, std::pair<int64_t, int>> out;
  for (const auto& [where, value] : keys) out[where] = {std::get<0>(value), std::get<1>(value)};
  return out;
}

// stored episodes whose length differs from the reference run's (same
// round, slot and episode; a resumed DAgger round may act differently)
int lengthDifferences(const StoreKeys& keys, const StoreKeys& reference) {
  int n = 0;
  for (const auto& [where, value] : keys)
    if (reference.count(where) && std::get<2>(reference.at(where)) != std::get<2>(value)) ++n;
  return n;
}

// names of the temporary files of atomic writes (*.tmp.*) in `dir`
std::set<std::string> tempFiles(const fs::path& dir) {
  std::set<std::string> names;
  std::error_code ec;
  for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator(); ++it)
    if (it->path().filename().string().find(".tmp.") != std::string::npos)
      names.insert(it->path().filename().string());
  return names;
}

// true when `dir` holds a temporary file that is not in `before` (one that
// a kill left behind does not count)
bool newTempFile(const fs::path& dir, const std::set<std::string>& before) {
  for (const auto& name : tempFiles(dir))
    if (!before.count(name)) return true;
  return false;
}

std::optional<fs::file_time_type> mtime(const fs::path& file) {
  std::error_code ec;
  auto t = fs::last_write_time(file, ec);
  if (ec) return std::nullopt;
  return t;
}

// DAgger rounds of both runs: enough work that ten kills, each losing at
// most the step in flight, come before the run finishes (with 3 rounds it
// finished after 8 kills on the CI machine)
constexpr int kRounds = 6;

// collection one environment at a time, so that a round resumed with other
// episodes side by side computes the same features and actions
const std::string kExact = "  exact_resume: true\n";

bool exited(pid_t pid, int* status) { return ::waitpid(pid, status, WNOHANG) == pid; }

class KillResumeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    for (const char* name : {"train", "vlnce-data"})
      if (!fs::exists(binary(name))) GTEST_SKIP() << "build the " << name << " binary first";
  }
  std::vector<std::string> trainArgs(const fs::path& config, bool resume) {
    std::vector<std::string> args = {binary("train"), "--config", config.string()};
    if (resume) args.push_back("--resume");
    return args;
  }
  vln::test::TempDir dir_;
};

TEST_F(KillResumeTest, RandomKillsLoseAndDuplicateNothing) {
  const int kills = envInt("VLN_KILL_COUNT", 10);
  std::mt19937_64 rng(static_cast<uint64_t>(envInt("VLN_KILL_SEED", 1)));

  // the reference run
  const fs::path refRun = dir_ / "reference";
  const fs::path refConfig =
      vln::test::writeText(dir_ / "reference.yaml", daggerRunConfig(refRun, kRounds, 5, kExact));
  const auto refStart = Clock::now();
  {
    int status = 0;
    const pid_t pid = spawn(trainArgs(refConfig, false), dir_ / "reference.log");
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
        << "reference run failed, see " << (dir_ / "reference.log");
  }
  const double refSeconds = std::chrono::duration<double>(Clock::now() - refStart).count();
  const StoreKeys reference = storeKeys(refRun / "store");
  ASSERT_EQ(reference.size(), static_cast<size_t>(kRounds * 5));
  std::vector<int> refCheckpoints;
  for (const auto& f : train::listCheckpoints(refRun / "checkpoints"))
    refCheckpoints.push_back(*train::checkpointIndex(f));

  // the killed run
  const fs::path run = dir_ / "killed";
  const fs::path config = vln::test::writeText(dir_ / "killed.yaml", daggerRunConfig(run, kRounds, 5, kExact));
  const fs::path log = dir_ / "killed.log";
  int done = 0, duringCheckpointWrite = 0, nearStoreCommit = 0, attempts = 0;
  bool finished = false;
  // short enough that the run cannot finish within `kills` attempts
  std::uniform_real_distribution<double> delay(0.2, std::max(0.5, refSeconds / 3));
  while (done < kills) {
    ++attempts;
    ASSERT_LT(attempts, kills * 4) << "the run keeps finishing before it can be killed";
    const bool resume = fs::exists(run / "config.yaml");
    const pid_t pid = spawn(trainArgs(config, resume), log);
    const int trigger = done % 3;  // 0 random, 1 checkpoint write, 2 store commit
    const auto start = Clock::now();
    // every trigger also fires at a random deadline: once all episodes are
    // stored no store commit comes, and waiting for one let the run finish
    // after 8 kills on an idle machine
    const auto deadline = start + std::chrono::duration<double>(delay(rng));
    const auto storeFile = run / "store" / "data.mdb";
    const auto storeBefore = mtime(storeFile);
    const auto tempsBefore = tempFiles(run / "checkpoints");
    int status = 0;
    bool killed = false, exitedAlone = false;
    while (!killed) {
      if (exited(pid, &status)) {
        exitedAlone = true;
        break;
      }
      bool fire = Clock::now() >= deadline;
      if (trigger == 1 && newTempFile(run / "checkpoints", tempsBefore)) fire = true;
      if (trigger == 2 && mtime(storeFile) != storeBefore) {
        std::this_thread::sleep_for(std::chrono::microseconds(
            std::uniform_int_distribution<int>(0, 3000)(rng)));
        fire = true;
      }
      if (fire) {
        if (newTempFile(run / "checkpoints", tempsBefore)) ++duringCheckpointWrite;
        if (mtime(storeFile) != storeBefore) ++nearStoreCommit;
        ::kill(pid, SIGKILL);
        ::waitpid(pid, &status, 0);
        killed = true;
      } else {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
    }
    if (exitedAlone) {
      ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
          << "train failed on its own (status " << status << "), see " << log;
      finished = true;
      break;  // it completed before this kill: nothing left to interrupt
    }
    ++done;
    std::cout << "kill " << done << " (trigger " << trigger << ") after "
              << std::chrono::duration<double>(Clock::now() - start).count() << " s\n";

    // invariants after every kill
    SCOPED_TRACE("after kill " + std::to_string(done));
    int64_t claimed = 0;
    if (fs::exists(run / "checkpoints"))
      for (const auto& file : train::listCheckpoints(run / "checkpoints")) {
        train::Checkpoint c;
        ASSERT_NO_THROW(c = train::loadCheckpoint(file)) << file;
        claimed = std::max(claimed, c.progress.episodes_collected);
      }
    if (fs::exists(storeFile)) {
      StoreKeys keys;
      try {
        keys = storeKeys(run / "store");
      } catch (const std::exception& e) {
        // a store killed before its first commit holds no meta record yet
        EXPECT_EQ(claimed, 0) << e.what();
      }
      for (const auto& [where, value] : keys) {
        ASSERT_TRUE(reference.count(where)) << "unexpected round/slot " << where.first << "/"
                                            << where.second;
        EXPECT_EQ(std::get<0>(reference.at(where)), std::get<0>(value))
            << "round " << where.first << " slot " << where.second << " holds another episode";
        EXPECT_EQ(std::get<1>(reference.at(where)), std::get<1>(value))
            << "round " << where.first << " slot " << where.second << " has another source";
      }
      EXPECT_GE(static_cast<int64_t>(keys.size()), claimed)
          << "a checkpoint counts episodes the store does not hold";
    }
  }

  // resume to the end without kills (a fresh start when every kill came
  // before the run wrote its config, as on a loaded machine: --resume
  // rightly refuses a directory that holds no run)
  if (!finished) {
    int status = 0;
    const pid_t pid =
        spawn(trainArgs(config, fs::exists(run / "config.yaml")), log);
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
        << "final resume failed (status " << status << "); its log:\n"
        << vln::test::readText(log);
  }
  // kills during checkpoint writes leave temporaries; resuming removes them
  const auto leftover = tempFiles(run / "checkpoints");
  std::cout << "temporary files left in checkpoints/: " << leftover.size() << "\n";
  RecordProperty("leftover_temp_files", static_cast<int>(leftover.size()));
  EXPECT_TRUE(leftover.empty()) << *leftover.begin();
  std::cout << "kills " << done << ", during a checkpoint write " << duringCheckpointWrite
            << ", near a store commit " << nearStoreCommit << ", reference run " << refSeconds
            << " s\n";
  RecordProperty("kills", done);
  RecordProperty("kills_during_checkpoint_write", duringCheckpointWrite);
  RecordProperty("kills_near_store_commit", nearStoreCommit);
  EXPECT_GE(done, kills);
  EXPECT_TRUE(fs::exists(run / "finished.json"));
  const StoreKeys final = storeKeys(run / "store");
  EXPECT_EQ(ids(final), ids(reference)) << "episodes lost or duplicated";
  const int lengths = lengthDifferences(final, reference);
  std::cout << "stored episodes whose length differs from the reference run: " << lengths << "\n";
  RecordProperty("episode_length_differences", lengths);
  EXPECT_EQ(lengths, 0);
  std::vector<int> indices;
  for (const auto& f : train::listCheckpoints(run / "checkpoints")) {
    indices.push_back(*train::checkpointIndex(f));
    EXPECT_NO_THROW(train::loadCheckpoint(f)) << f;
  }
  EXPECT_EQ(indices, refCheckpoints);
  const auto last = train::loadCheckpoint(train::listCheckpoints(run / "checkpoints").back());
  const auto refLast = train::loadCheckpoint(train::listCheckpoints(refRun / "checkpoints").back());
  EXPECT_EQ(last.progress.episodes_collected, refLast.progress.episodes_collected);
  EXPECT_EQ(last.progress.dagger_iteration, refLast.progress.dagger_iteration);
  // an epoch cut by a kill restarts from the last checkpoint with its RNG
  // state, a round cut by a kill collects the same features and actions
  // (exact_resume) and batches are drawn in (round, slot) order: the
  // resumed run ends bit for bit where the reference run ends
  bool sameWeights = last.policy.size() == refLast.policy.size();
  for (size_t i = 0; sameWeights && i < last.policy.size(); ++i)
    sameWeights = last.policy[i].first == refLast.policy[i].first &&
                  torch::equal(last.policy[i].second, refLast.policy[i].second);
  std::cout << "final weights " << (sameWeights ? "equal" : "differ from")
            << " the reference run's\n";
  RecordProperty("final_weights_equal_reference", sameWeights ? 1 : 0);
  EXPECT_TRUE(sameWeights) << "the resumed run's final weights differ from the reference run's";
  EXPECT_EQ(last.optimizer_state, refLast.optimizer_state)
      << "the resumed run's final Adam state differs from the reference run's";
}

}  // namespace
}  // namespace vln::reliability
