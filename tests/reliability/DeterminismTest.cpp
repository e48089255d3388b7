// Determinism: (a) two tiny DAgger runs on the CPU with the same seed and
// thread counts write byte-identical checkpoint tensors, optimizer and RNG
// states, identical stores and identical metrics (timings aside);
// (b) evaluating a checkpoint twice, and with another eval.threads and
// eval.num_envs, gives identical stats and per-episode files; (c) the
// generated world is byte-identical for a seed, whatever --threads;
// (d) training does not depend on the vector units the CPU offers
// (common::pinNumericalRuntime), and does without the pin where the CPU has
// AVX-512, so the comparison can fail; (e) nor does the waypoint agent's
// training, its predictor's included.
// Label "slow": these drive the train, eval and vlnce-data binaries.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>
#include <cstring>

#include "ReliabilityWorld.h"
#include "common/Json.h"
#include "train/Checkpoint.h"
#include "train/FeatureStore.h"

namespace vln::reliability {
namespace {

using ::testing::IsEmpty;

std::string fileBytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// relative path -> contents of every regular file under `root`
std::map<std::string, std::string> tree(const fs::path& root) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.is_regular_file()) files[fs::relative(e.path(), root).string()] = fileBytes(e.path());
  return files;
}

// the relative paths whose contents differ or exist on one side only
std::vector<std::string> treeDifferences(const fs::path& a, const fs::path& b) {
  const auto ta = tree(a), tb = tree(b);
  std::vector<std::string> diff;
  for (const auto& [name, bytes] : ta)
    if (!tb.count(name) || tb.at(name) != bytes) diff.push_back(name);
  for (const auto& [name, bytes] : tb)
    if (!ta.count(name)) diff.push_back(name + " (only in the second)");
  return diff;
}

// what a checkpoint must reproduce, every tensor compared bit for bit
void expectSameCheckpoint(const fs::path& a, const fs::path& b) {
  SCOPED_TRACE(a.filename().string());
  const train::Checkpoint ca = train::loadCheckpoint(a), cb = train::loadCheckpoint(b);
  ASSERT_EQ(ca.policy.size(), cb.policy.size());
  for (size_t i = 0; i < ca.policy.size(); ++i) {
    EXPECT_EQ(ca.policy[i].first, cb.policy[i].first);
    const torch::Tensor& x = ca.policy[i].second;
    const torch::Tensor& y = cb.policy[i].second;
    ASSERT_EQ(x.sizes(), y.sizes()) << ca.policy[i].first;
    ASSERT_EQ(x.dtype(), y.dtype()) << ca.policy[i].first;
    const auto bytes = static_cast<size_t>(x.numel() * x.element_size());
    EXPECT_EQ(std::memcmp(x.contiguous().data_ptr(), y.contiguous().data_ptr(), bytes), 0)
        << ca.policy[i].first << " differs";
  }
  EXPECT_TRUE(ca.optimizer_state == cb.optimizer_state) << "optimizer state differs";
  EXPECT_TRUE(ca.rng_state == cb.rng_state) << "RNG state differs";
  EXPECT_EQ(ca.progress.updates, cb.progress.updates);
  EXPECT_EQ(ca.progress.episodes_collected, cb.progress.episodes_collected);
  EXPECT_EQ(ca.progress.best_spl, cb.progress.best_spl);
  EXPECT_EQ(ca.progress.extra, cb.progress.extra);
}

void expectSameStore(const fs::path& a, const fs::path& b) {
  auto sa = train::FeatureStore::openExisting(a), sb = train::FeatureStore::openExisting(b);
  ASSERT_EQ(sa->size(), sb->size());
  for (int64_t i = 0; i < sa->size(); ++i) {
    const auto ea = sa->read(i), eb = sb->read(i);
    EXPECT_EQ(ea.key.episode_id, eb.key.episode_id) << i;
    EXPECT_EQ(ea.key.iteration, eb.key.iteration) << i;
    EXPECT_EQ(ea.key.slot, eb.key.slot) << i;
    EXPECT_EQ(ea.oracle_actions, eb.oracle_actions) << i;
    EXPECT_EQ(ea.prev_actions, eb.prev_actions) << i;
    if (ea.rgb.defined()) {
      EXPECT_TRUE(torch::equal(ea.rgb, eb.rgb)) << i;
    }
    if (ea.depth.defined()) {
      EXPECT_TRUE(torch::equal(ea.depth, eb.depth)) << i;
    }
  }
}

// whether any policy tensor of two checkpoints differs
bool policiesDiffer(const fs::path& a, const fs::path& b) {
  const train::Checkpoint ca = train::loadCheckpoint(a), cb = train::loadCheckpoint(b);
  for (size_t i = 0; i < ca.policy.size() && i < cb.policy.size(); ++i)
    if (!torch::equal(ca.policy[i].second, cb.policy[i].second)) return true;
  return false;
}

// what an AVX-512 machine's libraries pick by themselves, asked for explicitly
const std::string kAskForAvx512 =
    "ATEN_CPU_CAPABILITY=avx512 DNNL_MAX_CPU_ISA=AVX512_CORE "
    "ONEDNN_MAX_CPU_ISA=AVX512_CORE OPENBLAS_CORETYPE=SkylakeX";

// what a CPU without AVX-512 renders with: the renderer's portable path
// (an AVX-512 CPU sets up and shades its rays with AVX-512 instead)
const std::string kPortableRenderer = "VLN_EMBREE_SHADING=scalar";

// the two runs' metrics.jsonl record for record, timings aside
void expectSameMetrics(const fs::path& a, const fs::path& b) {
  auto records = [](const fs::path& run) {
    std::vector<nlohmann::json> out;
    for (auto& r : readJsonLines(run / "metrics.jsonl")) out.push_back(withoutTimings(r));
    return out;
  };
  const auto ma = records(a), mb = records(b);
  ASSERT_EQ(ma.size(), mb.size());
  for (size_t i = 0; i < ma.size(); ++i) EXPECT_EQ(ma[i], mb[i]) << "metrics record " << i;
}

class DeterminismTest : public ::testing::Test {
 protected:
  void SetUp() override {
    for (const char* name : {"train", "eval", "vlnce-data"})
      if (!fs::exists(binary(name))) GTEST_SKIP() << "build the " << name << " binary first";
  }
  // runs the train binary on the config `yaml` (whose output.dir is
  // <dir>/<name>) with the environment variables `env` ("A=1 B=2");
  // returns the run directory
  fs::path trainConfig(const std::string& name, const std::string& yaml,
                       const std::string& env) {
    const fs::path config = vln::test::writeText(dir_ / (name + ".yaml"), yaml);
    std::string output;
    EXPECT_EQ(vln::test::runCommand("env " + env + " " + binary("train") + " --config " +
                                        config.string(),
                                    &output),
              0)
        << name << ": " << output;
    return dir_ / name;
  }
  // the tiny DAgger run
  fs::path train(const std::string& name, const std::string& env = "") {
    return trainConfig(name, daggerRunConfig(dir_ / name, 2, 3), env);
  }
  vln::test::TempDir dir_;
};

TEST_F(DeterminismTest, TrainingAndEvaluationAreReproducible) {
  const fs::path a = train("a"), b = train("b");
  const auto checkpoints = train::listCheckpoints(a / "checkpoints");
  ASSERT_FALSE(checkpoints.empty());
  ASSERT_EQ(checkpoints.size(), train::listCheckpoints(b / "checkpoints").size());
  for (const auto& file : checkpoints)
    expectSameCheckpoint(file, b / "checkpoints" / file.filename());
  expectSameStore(a / "store", b / "store");
  expectSameMetrics(a, b);
  EXPECT_EQ(fileBytes(a / "checkpoints" / "best.json"), fileBytes(b / "checkpoints" / "best.json"));

  // (b) one checkpoint evaluated three times: again, and with more threads
  // and environments; stats and per-episode files must agree exactly
  const fs::path config = dir_ / "a.yaml";
  auto evaluate = [&](const std::string& out, int threads, int envs) {
    std::string output;
    EXPECT_EQ(vln::test::runCommand(binary("eval") + " --config " + config.string() +
                                        " --checkpoint " + checkpoints.back().string() +
                                        " --out " + (dir_ / out).string() +
                                        " --episodes 4 --set eval.save_episodes=true" +
                                        " --set eval.threads=" + std::to_string(threads) +
                                        " --set eval.num_envs=" + std::to_string(envs),
                                    &output),
              0)
        << output;
    return dir_ / out;
  };
  const fs::path e1 = evaluate("eval1", 1, 2), e2 = evaluate("eval2", 1, 2),
                 e3 = evaluate("eval3", 2, 3);
  const auto files = tree(e1);
  ASSERT_FALSE(files.empty());
  for (const fs::path& other : {e2, e3}) {
    SCOPED_TRACE(other.filename().string());
    for (const auto& [name, bytes] : files) {
      ASSERT_TRUE(fs::exists(other / name)) << name;
      if (name.ends_with(".json")) {
        EXPECT_EQ(withoutTimings(common::readJsonFile(e1 / name)),
                  withoutTimings(common::readJsonFile(other / name)))
            << name;
      } else if (name.ends_with(".json.gz")) {
        EXPECT_TRUE(common::readFile(e1 / name) == common::readFile(other / name)) << name;
      }
    }
  }
}

// (d) what an AVX-512 machine's libraries pick by themselves, asked for
// explicitly, and the renderer's path of a CPU without AVX-512: the pinned
// binary trains the same weights as with no such request; with
// VLN_NATIVE_DISPATCH=1 they differ (on a CPU with AVX-512)
TEST_F(DeterminismTest, TrainingDoesNotDependOnTheCpusVectorUnits) {
  if (!__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma"))
    GTEST_SKIP() << "the pin needs AVX2 and FMA";
  const fs::path pinned = train("pinned"), asked = train("asked", kAskForAvx512);
  const auto checkpoints = train::listCheckpoints(pinned / "checkpoints");
  ASSERT_FALSE(checkpoints.empty());
  const fs::path last = checkpoints.back().filename();
  expectSameCheckpoint(pinned / "checkpoints" / last, asked / "checkpoints" / last);
  const fs::path portable = train("portable", kPortableRenderer);
  expectSameCheckpoint(pinned / "checkpoints" / last,
                       portable / "checkpoints" / last);
  if (!__builtin_cpu_supports("avx512f"))
    GTEST_SKIP() << "no AVX-512 here: native dispatch would pick AVX2 too";
  const fs::path native = train("native", "VLN_NATIVE_DISPATCH=1 " + kAskForAvx512);
  EXPECT_TRUE(policiesDiffer(pinned / "checkpoints" / last, native / "checkpoints" / last))
      << "AVX-512 kernels trained the same weights: this test no longer shows that the pin "
         "matters";
}

// (e) the waypoint agent's path (issue 18) under the same pin: the candidate
// waypoint predictor's training, then the waypoint CMA's collection over its
// candidates and training, asked for AVX-512 kernels, write the same bytes;
// so do both rendered with the portable path of CPUs without AVX-512; with
// VLN_NATIVE_DISPATCH=1 on an AVX-512 CPU the agent's weights differ. (An
// AVX-512 machine's waypoint run once validated other numbers than an AVX2
// machine's: the renderer's two paths rounded differently until 2026-11-29;
// docs/reliability.md, "Across machines".)
TEST_F(DeterminismTest, WaypointTrainingDoesNotDependOnTheCpusVectorUnits) {
  if (!__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma"))
    GTEST_SKIP() << "the pin needs AVX2 and FMA";
  const std::string waypointSections =
      "panorama:\n"
      "  rgb: {width: 32, height: 32}\n"
      "  depth: {width: 32, height: 32}\n"
      "waypoint:\n"
      "  predictor: {hidden_size: 32, ff_size: 32}\n"
      "  headings_per_node: 1\n"
      "  max_nodes_per_house: 3\n"
      "  epochs: 2\n";
  auto predictor = [&](const std::string& name, const std::string& env) {
    const std::string yaml =
        train::test::tinyRunConfig(reliabilityWorld(), dir_ / name,
                                   "  task: waypoint_predictor\n") +
        waypointSections;
    return trainConfig(name, yaml, env) / "waypoint_predictor.pt";
  };
  auto agent = [&](const std::string& name, const fs::path& weights, const std::string& env) {
    const std::string yaml =
        train::test::tinyRunConfig(reliabilityWorld(), dir_ / name,
                                   "  task: waypoint_cma\n"
                                   "  dagger_iterations: 2\n"
                                   "  dagger_episodes: 6\n"
                                   "  dagger_epochs: 1\n") +
        waypointSections + "waypoint_agent:\n  max_decisions: 6\n  predictor_weights: " +
        weights.string() + "\n";
    return trainConfig(name, yaml, env);
  };
  const fs::path pinnedWeights = predictor("predictor_pinned", "");
  const fs::path askedWeights = predictor("predictor_asked", kAskForAvx512);
  ASSERT_TRUE(fs::exists(pinnedWeights));
  EXPECT_TRUE(fileBytes(pinnedWeights) == fileBytes(askedWeights))
      << "the predictor's weights depend on the kernels asked for";
  const fs::path pinned = agent("agent_pinned", pinnedWeights, "");
  const fs::path asked = agent("agent_asked", askedWeights, kAskForAvx512);
  const auto checkpoints = train::listCheckpoints(pinned / "checkpoints");
  ASSERT_FALSE(checkpoints.empty());
  const fs::path last = checkpoints.back().filename();
  expectSameCheckpoint(pinned / "checkpoints" / last, asked / "checkpoints" / last);
  expectSameMetrics(pinned, asked);

  const fs::path portableWeights =
      predictor("predictor_portable", kPortableRenderer);
  EXPECT_TRUE(fileBytes(pinnedWeights) == fileBytes(portableWeights))
      << "the predictor's weights depend on the renderer's path";
  const fs::path portable =
      agent("agent_portable", portableWeights, kPortableRenderer);
  expectSameCheckpoint(pinned / "checkpoints" / last,
                       portable / "checkpoints" / last);
  expectSameMetrics(pinned, portable);

  if (!__builtin_cpu_supports("avx512f"))
    GTEST_SKIP() << "no AVX-512 here: native dispatch would pick AVX2 too";
  const std::string nativeEnv = "VLN_NATIVE_DISPATCH=1 " + kAskForAvx512;
  const fs::path native =
      agent("agent_native", predictor("predictor_native", nativeEnv), nativeEnv);
  EXPECT_TRUE(policiesDiffer(pinned / "checkpoints" / last, native / "checkpoints" / last))
      << "AVX-512 kernels trained the same waypoint agent: this test no longer shows that the "
         "pin matters";
}

// (c) the world of configs/world/tiny.yaml, generated twice with different
// thread counts, is the same bytes in every file
TEST_F(DeterminismTest, GeneratedWorldIsByteIdentical) {
  const std::string tiny = (vln::test::sourcePath() / "configs" / "world" / "tiny.yaml").string();
  for (const auto& [name, threads] : {std::pair{"w1", 1}, std::pair{"w2", 2}}) {
    std::string output;
    ASSERT_EQ(vln::test::runCommand(binary("vlnce-data") + " generate --config " + tiny +
                                        " --houses 2 --out " + (dir_ / name / "data").string() +
                                        " --scenes-dir " + (dir_ / name / "scenes").string() +
                                        " --threads " + std::to_string(threads),
                                    &output),
              0)
        << output;
  }
  EXPECT_GT(tree(dir_ / "w1").size(), 5u);
  EXPECT_THAT(treeDifferences(dir_ / "w1", dir_ / "w2"), IsEmpty());
}

}  // namespace
}  // namespace vln::reliability
