// Tests of src/train/Checkpoint.cpp: round trip (policy, optimizer state,
// progress, RNG bytes), resuming equals continuing, strict loading errors,
// corrupt files, and a full disk (RLIMIT_FSIZE) leaving the previous
// checkpoint intact.

#include "train/Checkpoint.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <fstream>

#include "common/FileIo.h"
#include "models/Loss.h"
#include "models/ModelTestUtil.h"
#include "support/TestPaths.h"

namespace vln::train {
namespace {

using ::testing::HasSubstr;

// the model tests' tiny CMA (models/ModelTestUtil.h) with 17 tokens
models::ModelConfig tinyModel() {
  models::ModelConfig c = models::test::tinyConfig(models::PolicyType::kCma);
  c.vocab_size = 17;
  return c;
}

// one deterministic imitation step on fixed random inputs
void trainStep(models::PolicyImpl& policy, torch::optim::Adam& adam,
               uint64_t seed) {
  torch::manual_seed(seed);
  const auto& c = policy.config();
  const int64_t T = 4, B = 2;
  const models::PolicyInputs in = models::test::randomInputs(c, T, B);
  const torch::Tensor tokens =
      torch::randint(1, c.vocab_size, {B, 5}, torch::kInt64);
  const torch::Tensor actions = torch::randint(0, 4, {T, B}, torch::kInt64);
  const torch::Tensor valid = torch::ones({T, B}, torch::kBool);
  adam.zero_grad();
  auto out = policy.forwardSequence(policy.encodeInstruction(tokens), in,
                                    policy.initialHidden(B));
  auto loss = models::weightedActionLoss(
      out.logits, actions, models::inflectionWeights(actions, valid, 3.2));
  loss.backward();
  adam.step();
}

Checkpoint makeCheckpoint(models::PolicyImpl& policy,
                          torch::optim::Adam& adam) {
  Checkpoint ckpt;
  ckpt.config_yaml = "trainer:\n  lr: 0.001\n";
  for (const auto& [name, tensor] : models::namedState(policy))
    ckpt.policy.emplace_back(name, tensor.clone());
  ckpt.optimizer_state = serializeOptimizer(adam);
  ckpt.progress.checkpoint_index = 3;
  ckpt.progress.dagger_iteration = 2;
  ckpt.progress.epoch = 1;
  ckpt.progress.updates = 1234567890123;
  ckpt.progress.episodes_collected = 77;
  ckpt.progress.stage = "dagger";
  ckpt.progress.best_spl = 0.25;
  ckpt.progress.best_checkpoint = 2;
  ckpt.progress.extra = {{"inflection_coef", 3.5}};
  ckpt.rng_state = std::string("\0\x01\xff binary", 10);
  return ckpt;
}

TEST(CheckpointTest, FileNamesAndIndices) {
  EXPECT_EQ(checkpointFileName(12), "ckpt.12.pth");
  EXPECT_EQ(checkpointIndex("runs/x/ckpt.12.pth"), 12);
  EXPECT_EQ(checkpointIndex("ckpt.pth"), std::nullopt);
  EXPECT_EQ(checkpointIndex("ckpt.1a.pth"), std::nullopt);
  EXPECT_EQ(checkpointIndex("ckpt.-1.pth"), std::nullopt);
  EXPECT_EQ(checkpointIndex("ckpt.3.pth.tmp.5.0"), std::nullopt);
  test::TempDir dir;
  for (int i : {10, 2, 1}) test::writeText(dir / checkpointFileName(i), "x");
  test::writeText(dir / "best.json", "{}");
  auto files = listCheckpoints(dir.path());
  ASSERT_EQ(files.size(), 3u);
  EXPECT_EQ(files[0].filename(), "ckpt.1.pth");
  EXPECT_EQ(files[2].filename(), "ckpt.10.pth");
  EXPECT_TRUE(listCheckpoints(dir / "missing").empty());
}

TEST(CheckpointTest, RoundTripThenOneMoreStepEqualsContinuing) {
  torch::manual_seed(0);
  auto policy = models::makePolicy(tinyModel());
  torch::optim::Adam adam(policy->parameters(),
                          torch::optim::AdamOptions(1e-2));
  trainStep(*policy, adam, 1);
  trainStep(*policy, adam, 2);

  test::TempDir dir;
  const Checkpoint saved = makeCheckpoint(*policy, adam);
  saveCheckpoint(dir / "ckpt.3.pth", saved);
  const Checkpoint loaded = loadCheckpoint(dir / "ckpt.3.pth");
  EXPECT_EQ(loaded.config_yaml, saved.config_yaml);
  EXPECT_EQ(loaded.rng_state, saved.rng_state);
  EXPECT_EQ(loaded.progress.updates, 1234567890123);
  EXPECT_EQ(loaded.progress.stage, "dagger");
  EXPECT_EQ(loaded.progress.best_checkpoint, 2);
  EXPECT_DOUBLE_EQ(loaded.progress.best_spl, 0.25);
  EXPECT_EQ(loaded.progress.extra["inflection_coef"].get<double>(), 3.5);
  ASSERT_EQ(loaded.policy.size(), saved.policy.size());
  for (size_t i = 0; i < saved.policy.size(); ++i) {
    EXPECT_EQ(loaded.policy[i].first, saved.policy[i].first);
    EXPECT_TRUE(torch::equal(loaded.policy[i].second, saved.policy[i].second));
  }

  // a fresh policy and optimizer restored from the file
  torch::manual_seed(99);
  auto resumed = models::makePolicy(tinyModel());
  models::loadStateStrict(*resumed, loaded.policy, "ckpt.3.pth");
  torch::optim::Adam resumedAdam(resumed->parameters(),
                                 torch::optim::AdamOptions(1e-2));
  loadOptimizerState(resumedAdam, loaded.optimizer_state, "ckpt.3.pth");

  trainStep(*policy, adam, 3);
  trainStep(*resumed, resumedAdam, 3);
  const auto a = models::namedState(*policy);
  const auto b = models::namedState(*resumed);
  for (size_t i = 0; i < a.size(); ++i)
    EXPECT_TRUE(torch::equal(a[i].second, b[i].second)) << a[i].first;

  // without the optimizer state the next step differs (Adam's moments)
  torch::manual_seed(98);
  auto fresh = models::makePolicy(tinyModel());
  models::loadStateStrict(*fresh, loaded.policy, "ckpt.3.pth");
  torch::optim::Adam freshAdam(fresh->parameters(),
                               torch::optim::AdamOptions(1e-2));
  trainStep(*fresh, freshAdam, 3);
  bool anyDiffers = false;
  const auto f = models::namedState(*fresh);
  for (size_t i = 0; i < a.size(); ++i)
    anyDiffers |= !torch::equal(a[i].second, f[i].second);
  EXPECT_TRUE(anyDiffers);
}

TEST(CheckpointTest, StrictLoadingNamesMissingAndMismatchedTensors) {
  torch::manual_seed(0);
  auto policy = models::makePolicy(tinyModel());
  torch::optim::Adam adam(policy->parameters());
  Checkpoint ckpt = makeCheckpoint(*policy, adam);
  const std::string dropped = ckpt.policy.back().first;
  ckpt.policy.pop_back();
  ckpt.policy[0].second = torch::zeros({1, 2, 3});
  const std::string reshaped = ckpt.policy[0].first;
  test::TempDir dir;
  saveCheckpoint(dir / "ckpt.0.pth", ckpt);
  auto loaded = loadCheckpoint(dir / "ckpt.0.pth");
  auto other = models::makePolicy(tinyModel());
  try {
    models::loadStateStrict(*other, loaded.policy,
                            (dir / "ckpt.0.pth").string());
    FAIL() << "expected a strict-loading error";
  } catch (const std::invalid_argument& error) {
    EXPECT_THAT(error.what(), HasSubstr(dropped));
    EXPECT_THAT(error.what(), HasSubstr(reshaped));
    EXPECT_THAT(error.what(), HasSubstr("ckpt.0.pth"));
  }
  // another architecture's optimizer state does not fit
  models::ModelConfig seq = tinyModel();
  seq.policy = models::PolicyType::kSeq2Seq;
  auto seqPolicy = models::makePolicy(seq);
  torch::optim::Adam seqAdam(seqPolicy->parameters());
  trainStep(*policy, adam, 1);
  EXPECT_THROW(loadOptimizerState(seqAdam, serializeOptimizer(adam), "x.pth"),
               std::runtime_error);
}

TEST(CheckpointTest, TruncatedOrForeignFilesAreClearErrors) {
  torch::manual_seed(0);
  auto policy = models::makePolicy(tinyModel());
  torch::optim::Adam adam(policy->parameters());
  test::TempDir dir;
  saveCheckpoint(dir / "ckpt.0.pth", makeCheckpoint(*policy, adam));
  std::string bytes = common::readFile(dir / "ckpt.0.pth");
  test::writeText(dir / "ckpt.1.pth", bytes.substr(0, bytes.size() / 2));
  EXPECT_THAT(
      [&] { loadCheckpoint(dir / "ckpt.1.pth"); },
      ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("ckpt.1.pth")));
  // one flipped byte anywhere: LibTorch's reader does not check CRCs
  for (const size_t at : {bytes.size() / 3, bytes.size() / 2}) {
    std::string flipped = bytes;
    flipped[at] ^= 0x01;
    test::writeText(dir / "ckpt.3.pth", flipped);
    EXPECT_THAT([&] { loadCheckpoint(dir / "ckpt.3.pth"); },
                ::testing::ThrowsMessage<std::runtime_error>(
                    HasSubstr("ckpt.3.pth' is not an intact zip archive")))
        << "byte " << at;
  }
  test::writeText(dir / "ckpt.2.pth", "not a checkpoint");
  EXPECT_THAT(
      [&] { loadCheckpoint(dir / "ckpt.2.pth"); },
      ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("ckpt.2.pth")));
  EXPECT_THAT([&] { loadCheckpoint(dir / "ckpt.9.pth"); },
              ::testing::ThrowsMessage<std::runtime_error>(
                  HasSubstr("does not exist")));
}

// A child process with a file-size limit smaller than a checkpoint tries to
// overwrite one: it must fail with a clear error, and the old file must
// still load.
TEST(CheckpointTest, FileSizeLimitKeepsThePreviousCheckpoint) {
  torch::manual_seed(0);
  auto policy = models::makePolicy(tinyModel());
  torch::optim::Adam adam(policy->parameters());
  test::TempDir dir;
  const auto file = dir / "ckpt.0.pth";
  Checkpoint first = makeCheckpoint(*policy, adam);
  first.progress.updates = 1;
  saveCheckpoint(file, first);
  const auto size = std::filesystem::file_size(file);

  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    std::signal(SIGXFSZ, SIG_IGN);  // as common::runMain does
    rlimit limit{static_cast<rlim_t>(size / 2), static_cast<rlim_t>(size / 2)};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    Checkpoint second = first;
    second.progress.updates = 2;
    try {
      saveCheckpoint(file, second);
    } catch (const std::runtime_error& error) {
      const std::string message = error.what();
      const bool clear =
          message.find(file.string()) != std::string::npos &&
          message.find("previous file is intact") != std::string::npos;
      ::_exit(clear ? 7 : 8);
    }
    ::_exit(0);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 7);
  EXPECT_EQ(loadCheckpoint(file).progress.updates, 1);
  // no temporary file is left behind
  int entries = 0;
  for ([[maybe_unused]] const auto& e :
       std::filesystem::directory_iterator(dir.path()))
    ++entries;
  EXPECT_EQ(entries, 1);
}

}  // namespace
}  // namespace vln::train
