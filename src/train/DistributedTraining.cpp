#include "train/DistributedTraining.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <map>

#include "common/Check.h"
#include "common/Json.h"
#include "common/Random.h"
#include "train/RunDirectory.h"

namespace vln::train {
namespace fs = std::filesystem;

namespace {

bool isRankLocal(const std::string& key) {
  const auto& keys = rankLocalConfigKeys();
  return std::find(keys.begin(), keys.end(), key) != keys.end();
}

// "key=value" lines of every key that must agree between ranks
std::string sharedConfigText(const ExperimentConfig& config) {
  std::string text;
  for (const auto& [key, value] : flattenConfig(config))
    if (!isRankLocal(key)) text += key + "=" + value + "\n";
  return text;
}

std::map<std::string, std::string> parseLines(const std::string& text) {
  std::map<std::string, std::string> values;
  size_t begin = 0;
  while (begin < text.size()) {
    size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    const std::string line = text.substr(begin, end - begin);
    const size_t eq = line.find('=');
    if (eq != std::string::npos)
      values[line.substr(0, eq)] = line.substr(eq + 1);
    begin = end + 1;
  }
  return values;
}

}  // namespace

std::unique_ptr<Distributed> connectForTraining(ExperimentConfig& config) {
  const TrainerConfig& t = config.trainer;
  const std::optional<DistributedEnv> env = distributedEnvFromEnvironment();
  if (!env) return nullptr;
  if (t.distributed == "off") {
    spdlog::warn(
        "WORLD_SIZE={} is set but trainer.distributed is off: this process "
        "trains alone",
        env->world_size);
    return nullptr;
  }
  // the backend: NCCL for GPU models when this LibTorch has it
  const bool cudaModel = config.model.device.rfind("cuda", 0) == 0;
  DistributedOptions options;
  if (t.distributed_backend == "nccl") {
    VLN_CHECK_ARG(ncclCompiledIn(),
                  "train: trainer.distributed_backend is nccl but this "
                  "LibTorch build has no NCCL (use gloo or auto)");
    VLN_CHECK_ARG(cudaModel && torch::cuda::is_available(),
                  "train: trainer.distributed_backend nccl needs a CUDA "
                  "model.device and a visible GPU, got model.device '",
                  config.model.device, "' (CUDA available: ",
                  torch::cuda::is_available() ? "yes" : "no", ")");
    options.backend = CollectiveBackend::kNccl;
  } else if (t.distributed_backend == "auto" && ncclCompiledIn() && cudaModel &&
             torch::cuda::is_available()) {
    options.backend = CollectiveBackend::kNccl;
  }
  options.timeout = std::chrono::milliseconds(
      static_cast<int64_t>(t.distributed_timeout_s * 1000.0));
  options.wait_timeout = std::chrono::milliseconds(
      static_cast<int64_t>(t.distributed_wait_s * 1000.0));
  options.bucket_bytes = std::max<int64_t>(
      1, static_cast<int64_t>(t.distributed_bucket_mib * 1024.0 * 1024.0));
  options.device_index = env->local_rank;
  // one GPU per process on a machine: the LOCAL_RANK-th
  if (config.model.device == "cuda")
    config.model.device = "cuda:" + std::to_string(env->local_rank);
  return Distributed::connect(*env, options);
}

const std::vector<std::string>& rankLocalConfigKeys() {
  static const std::vector<std::string> keys = {
      "output.dir",        "sim.scenes_dir",      "dataset.data_path",
      "model.rgb_weights", "model.depth_weights", "trainer.init_checkpoint",
      "model.device",      "output.log_level",    "trainer.env_threads",
      "eval.threads"};
  return keys;
}

std::string rankConfigHash(const ExperimentConfig& config) {
  return common::fnv1aHex(sharedConfigText(config));
}

void checkSameConfigOnAllRanks(Distributed& dist,
                               const ExperimentConfig& config) {
  const std::string mine = sharedConfigText(config);
  const std::string master = dist.broadcastBytes(dist.isMaster() ? mine : "");
  dist.collectively("the config check", [&] {
    if (mine == master) return;
    const auto a = parseLines(master);
    const auto b = parseLines(mine);
    std::string keys;
    int count = 0;
    for (const auto& [key, value] : b) {
      auto it = a.find(key);
      const std::string other = it == a.end() ? "(missing)" : it->second;
      if (other == value) continue;
      ++count;
      keys += strCat("\n  ", key, ": rank 0 has ", other, ", rank ",
                     dist.rank(), " has ", value);
    }
    std::string local;
    for (const auto& key : rankLocalConfigKeys())
      local += (local.empty() ? "" : ", ") + key;
    throw std::invalid_argument(strCat(
        "train: the config of rank ", dist.rank(), " (hash ", common::fnv1aHex(mine),
        ") differs from rank 0's (hash ", common::fnv1aHex(master), ") in ", count,
        " key(s):", keys, "\nevery rank must train the same config; only ",
        local, " may differ"));
  });
  spdlog::info("distributed: all {} ranks run config {}", dist.worldSize(),
               common::fnv1aHex(mine));
}

fs::path storeShardDir(const fs::path& runDir, int rank) {
  return runDir / "store" / ("rank" + std::to_string(rank));
}

fs::path rankLogFile(const fs::path& runDir, int rank) {
  return rank == 0 ? runDir / "train.log"
                   : runDir / ("train.rank" + std::to_string(rank) + ".log");
}

void checkRunWorldSize(const fs::path& runDir, int worldSize, bool resume) {
  // a fresh run, or no run at all (checkResumeConfig() says so)
  if (!resume || !fs::exists(runDir / "config.yaml")) return;
  const fs::path file = runDir / "distributed.json";
  int runWorld = 1;
  if (fs::exists(file))
    runWorld = common::requireField<int>(common::readJsonFile(file),
                                         "world_size", file.string());
  VLN_CHECK_ARG(runWorld == worldSize, "train --resume: the run in '",
                runDir.string(), "' was trained by ", runWorld,
                " process(es) (",
                runWorld > 1 ? file.string() : "it has no distributed.json",
                ") but WORLD_SIZE is now ", worldSize,
                ": resume it with WORLD_SIZE=", runWorld,
                " (each rank resumes its own store shard)");
}

void writeRunWorldSize(const fs::path& runDir, int worldSize) {
  VLN_ASSERT(worldSize > 1);
  common::writeJsonFile(runDir / "distributed.json",
                        {{"world_size", worldSize}}, 2);
}

}  // namespace vln::train
