#pragma once
// The `train` command's side of multi-process training (docs/distributed.md):
// joining the process group that torchrun's variables describe, checking
// that every rank runs the same config, and the per-rank files of a run
// directory:
//   store/rank<r>/        rank r's shard of the feature store
//   train.rank<r>.log     rank r's log (rank 0 keeps train.log)
//   distributed.json      {"world_size": N}, written by rank 0 when the run
//                         starts; --resume requires the same WORLD_SIZE
// Rank 0 alone writes config.yaml, checkpoints, metrics, TensorBoard events,
// evaluation stats and finished.json; on two machines the other ranks' run
// directories hold only their store shard and log.

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "train/Distributed.h"
#include "train/ExperimentConfig.h"

namespace vln::train {

/// The process group of a training run, or nullptr when the run is one
/// process (WORLD_SIZE unset or 1, or trainer.distributed = off, which logs
/// a warning when WORLD_SIZE > 1). Picks the backend
/// (trainer.distributed_backend; auto: nccl when model.device is CUDA,
/// CUDA is available and NCCL compiled in, else gloo) and, with CUDA, sets
/// model.device "cuda" to "cuda:<LOCAL_RANK>". Throws what
/// parseDistributedEnv() and Distributed::connect() throw, and
/// std::invalid_argument naming trainer.distributed_backend when nccl cannot
/// be used.
std::unique_ptr<Distributed> connectForTraining(ExperimentConfig& config);

/// Keys that may differ between ranks: where files are on each machine
/// (output.dir, sim.scenes_dir, dataset.data_path, model.rgb_weights,
/// model.depth_weights, trainer.init_checkpoint, which only rank 0 reads),
/// the GPU (model.device), the log level and the environment/evaluation
/// thread counts.
const std::vector<std::string>& rankLocalConfigKeys();

/// Hash (16 hex digits) of the config without rankLocalConfigKeys().
std::string rankConfigHash(const ExperimentConfig& config);

/// Throws on every rank when any rank's config differs from rank 0's in a
/// key outside rankLocalConfigKeys(); the failing rank's message lists the
/// keys with both values, the others quote it.
void checkSameConfigOnAllRanks(Distributed& dist,
                               const ExperimentConfig& config);

/// <runDir>/store/rank<rank>.
std::filesystem::path storeShardDir(const std::filesystem::path& runDir,
                                    int rank);

/// The log file of `rank`: train.log for rank 0, train.rank<r>.log else.
std::filesystem::path rankLogFile(const std::filesystem::path& runDir,
                                  int rank);

/// For --resume: throws std::invalid_argument when the run in `runDir` was
/// trained with another number of processes than `worldSize` (its
/// distributed.json, absent for a one-process run), naming both. A fresh
/// run checks nothing.
void checkRunWorldSize(const std::filesystem::path& runDir, int worldSize,
                       bool resume);

/// Writes <runDir>/distributed.json for a run of `worldSize` > 1 processes.
void writeRunWorldSize(const std::filesystem::path& runDir, int worldSize);

}  // namespace vln::train
