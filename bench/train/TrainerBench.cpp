// Trainer speed and memory on a small CPU config (32x32 images, small CNN
// encoders, a CMA policy with 64 hidden units):
//   BM_TeacherForcingEpoch  one epoch over a synthetic store (updates/s)
//   BM_DaggerCollection     one DAgger round (beta 0.5) on a tiny generated
//                           world: episodes/min and frames/s, batched or
//                           one environment at a time (exact_resume)
//   BM_StoreAppend          feature-store appends; bytes per step
//   BM_Crc32c               the record checksum the store verifies on every
//                           read (arg 1: the CPU's CRC32 instruction, 0: the
//                           portable table), bytes/s over a 200 KB record
// Every benchmark reports the process's peak RSS (getrusage, MiB). The
// world is generated once into $TMPDIR/vlnce_trainer_bench_world.
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <filesystem>
#include <string>

#include "common/Config.h"
#include "common/FileIo.h"
#include "data/Glove.h"
#include "train/Collector.h"
#include "train/Crc32c.h"
#include "train/ImitationLearner.h"
#include "world/WorldGenerator.h"

namespace {
namespace fs = std::filesystem;
using namespace vln;

double peakRssMiB() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) /
         1024.0;  // ru_maxrss is KiB on Linux
}

train::ExperimentConfig smallConfig(int vocab, int dim) {
  train::ExperimentConfig c;
  c.sim.rgb.width = c.sim.rgb.height = 32;
  c.sim.depth.camera.width = c.sim.depth.camera.height = 32;
  c.model.policy = models::PolicyType::kCma;
  c.model.rgb_encoder = models::EncoderType::kSmallCnn;
  c.model.depth_encoder = models::EncoderType::kSmallCnn;
  c.model.vocab_size = vocab;
  c.model.embedding_dim = dim;
  c.model.instruction_hidden_size = 32;
  c.model.hidden_size = 64;
  c.model.rgb_projection_size = 32;
  c.model.depth_projection_size = 32;
  c.model.spatial_embedding_dim = 16;
  c.model.progress_monitor = true;
  c.model.rgb_width = c.model.rgb_height = 32;
  c.model.depth_width = c.model.depth_height = 32;
  c.trainer.batch_size = 5;
  c.trainer.num_envs = 4;
  c.trainer.env_threads = 2;
  c.task.max_episode_steps = 150;
  return c;
}

train::StoreLayout layoutOf(const train::ExperimentConfig& c) {
  train::StoreLayout l;
  l.rgb_shape = models::rgbFeatureShape(c.model);
  l.depth_shape = models::depthFeatureShape(c.model);
  l.fp16 = c.trainer.store_fp16;
  l.config_hash = "bench";
  return l;
}

// episodes of 56 steps (the paper's mean of 55.88 actions)
train::StoredEpisode syntheticEpisode(const train::StoreLayout& l, int id) {
  train::StoredEpisode e;
  e.key.episode_id = id;
  e.key.slot = id;
  const int T = 56;
  e.tokens.assign(30, 5);
  e.rgb = torch::rand({T, l.rgb_shape[0], l.rgb_shape[1], l.rgb_shape[2]});
  e.depth =
      torch::rand({T, l.depth_shape[0], l.depth_shape[1], l.depth_shape[2]});
  for (int t = 0; t < T; ++t) {
    e.oracle_actions.push_back(
        static_cast<uint8_t>(t == T - 1 ? 0 : 1 + t % 3));
    e.prev_actions.push_back(
        static_cast<uint8_t>(t == 0 ? 0 : 1 + (t - 1) % 3));
    e.progress.push_back(static_cast<float>(t) / T);
  }
  return e;
}

void BM_TeacherForcingEpoch(benchmark::State& state) {
  torch::set_num_threads(static_cast<int>(state.range(1)));
  const auto c = smallConfig(100, 50);
  const fs::path dir = fs::temp_directory_path() / "vlnce_trainer_bench_store";
  fs::remove_all(dir);
  const auto episodes = static_cast<int>(state.range(0));
  int64_t steps = 0, updates = 0;
  {
    train::FeatureStore store(dir, layoutOf(c), 4.0);
    for (int i = 0; i < episodes; ++i)
      store.append(syntheticEpisode(store.layout(), i));
    auto policy = models::makePolicy(c.model);
    train::ImitationLearner learner(policy, c);
    int epoch = 0;
    for (auto _ : state) {
      const auto r = learner.trainEpoch(store, 1, epoch++);
      updates += r.updates;
      steps += r.mean.steps;
    }
    state.counters["bytes_per_step"] = store.bytesPerStep();
  }
  fs::remove_all(dir);
  state.counters["updates_per_s"] = benchmark::Counter(
      static_cast<double>(updates), benchmark::Counter::kIsRate);
  state.counters["steps_per_s"] = benchmark::Counter(
      static_cast<double>(steps), benchmark::Counter::kIsRate);
  state.counters["peak_rss_MiB"] = peakRssMiB();
}
BENCHMARK(BM_TeacherForcingEpoch)
    ->Args({100, 1})
    ->Args({100, 2})
    ->Unit(benchmark::kSecond)
    ->Iterations(1);

const fs::path& benchWorld() {
  static const fs::path root = [] {
    const fs::path r = fs::temp_directory_path() / "vlnce_trainer_bench_world";
    if (!fs::exists(r / "done")) {
      world::WorldConfig w;
      w.houses = 3;
      w.seed = 5;
      w.house.min_rooms = 4;
      w.house.max_rooms = 5;
      w.splits.val_unseen_fraction = 0.34f;
      w.splits.test_fraction = 0.0f;
      w.splits.train_per_house = 20;
      w.splits.val_seen_per_house = 1;
      w.splits.val_unseen_per_house = 2;
      w.splits.test_per_house = 0;
      w.splits.aug_per_house = 1;
      w.instructions.per_trajectory = 1;
      w.glove.epochs = 3;
      world::WorldOutput out;
      out.out = r / "data";
      out.scenes_dir = r / "scenes";
      out.threads = 2;
      world::generateWorld(w, out);
      common::writeFileAtomic(r / "done", "ok\n");
    }
    return r;
  }();
  return root;
}

void BM_DaggerCollection(benchmark::State& state) {
  torch::set_num_threads(1);
  const fs::path root = benchWorld();
  const auto embeddings =
      data::readEmbeddingsJson(root / "data" / "embeddings.json.gz");
  auto c = smallConfig(embeddings.rows, embeddings.dim);
  c.sim.scenes_dir = (root / "scenes").string();
  c.trainer.num_envs = static_cast<int>(state.range(0));
  c.trainer.env_threads = 2;
  c.trainer.exact_resume = state.range(1) != 0;
  const auto train =
      data::readEpisodes(data::splitEpisodesPath(root / "data", "train"));
  auto policy = models::makePolicy(c.model);
  {
    // an untrained policy's logits are near ties, so float rounding decides
    // whether it stops at once: a bias toward FORWARD makes the batched and
    // the one-at-a-time runs walk comparable trajectories
    torch::NoGradGuard noGrad;
    policy->named_parameters()["action_head.bias"].copy_(
        torch::tensor({-10.0f, 10.0f, 0.0f, 0.0f}));
  }
  models::ObservationEncoder encoder(c.model);
  auto scenes = std::make_shared<rollout::SceneCache>(c.sim);
  train::Collector collector(c, scenes, encoder);
  train::CollectionRound round;
  round.beta = 0.5;
  for (const auto& e : train.episodes) {
    round.episodes.push_back(&e);
    round.sources.push_back(0);
  }
  int64_t episodes = 0, steps = 0;
  double seconds = 0.0, bytesPerStep = 0.0;
  int iteration = 0;
  for (auto _ : state) {
    const fs::path dir =
        fs::temp_directory_path() / "vlnce_trainer_bench_collect";
    fs::remove_all(dir);
    train::FeatureStore store(dir, layoutOf(c), 4.0);
    round.iteration = iteration++;
    const auto stats = collector.collect(round, store, policy, nullptr);
    episodes += stats.episodes;
    steps += stats.steps;
    seconds += stats.seconds;
    bytesPerStep = store.bytesPerStep();
  }
  state.counters["episodes_per_min"] =
      60.0 * static_cast<double>(episodes) / seconds;
  state.counters["frames_per_s"] = static_cast<double>(steps) / seconds;
  state.counters["bytes_per_step"] = bytesPerStep;
  state.counters["peak_rss_MiB"] = peakRssMiB();
}
BENCHMARK(BM_DaggerCollection)
    ->ArgNames({"envs", "exact_resume"})
    ->Args({4, 0})
    ->Args({8, 0})
    ->Args({8, 1})
    ->Unit(benchmark::kSecond)
    ->Iterations(1);

void BM_StoreAppend(benchmark::State& state) {
  const auto c = smallConfig(100, 50);
  const fs::path dir = fs::temp_directory_path() / "vlnce_trainer_bench_append";
  fs::remove_all(dir);
  train::FeatureStore store(dir, layoutOf(c), 4.0);
  const auto episode = syntheticEpisode(store.layout(), 0);
  for (auto _ : state) store.append(episode);
  state.counters["bytes_per_step"] = store.bytesPerStep();
  state.counters["episodes_per_s"] = benchmark::Counter(
      static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  fs::remove_all(dir);
}
BENCHMARK(BM_StoreAppend)->Iterations(200);

// a record the size of a 61-step episode at 64x64 (3 KB per step)
void BM_Crc32c(benchmark::State& state) {
  std::string record(200 * 1024, '\0');
  for (size_t i = 0; i < record.size(); ++i)
    record[i] = static_cast<char>((i * 2654435761u) >> 24);
  const bool instruction = state.range(0) != 0;
  uint32_t crc = 0;
  for (auto _ : state) {
    crc ^= instruction ? train::crc32c(record) : train::crc32cPortable(record);
    benchmark::DoNotOptimize(crc);
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) *
                          static_cast<int64_t>(record.size()));
}
BENCHMARK(BM_Crc32c)->Arg(1)->Arg(0);

}  // namespace
