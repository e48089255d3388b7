#pragma once
// Data-parallel training across processes and machines (VLN-CE has no
// multi-GPU imitation learning: its issue #20), on LibTorch's c10d:
// ProcessGroupGloo on the CPU, ProcessGroupNCCL when this LibTorch was built
// with CUDA and NCCL (compile-time guard VLN_WITH_NCCL) and the model runs on
// a GPU. Rendezvous follows torchrun: RANK, WORLD_SIZE, LOCAL_RANK,
// MASTER_ADDR and MASTER_PORT, through a TCPStore that rank 0 hosts (or,
// under torchrun's static rendezvous, TORCHELASTIC_USE_AGENT_STORE=True,
// the one torchrun's agent hosts there, as PyTorch's env:// does).
//
// Every collective here must be called by every rank in the same order
// (c10d's rule). Collectives fail after DistributedOptions::timeout; the
// long, uneven phases of a run (collection, evaluation) end in waitForAll(),
// which polls the store instead and may wait much longer. A rank that fails
// calls abort(): the others stop at their next waitForAll() with its message
// instead of waiting out the timeout.
//
// c10d and gloo headers stay in Distributed.cpp (PIMPL).

#include <torch/torch.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace vln::train {

/// One process's place in a multi-process run, as torchrun exports it.
struct DistributedEnv {
  int rank = 0;        ///< RANK, in [0, world_size)
  int world_size = 1;  ///< WORLD_SIZE
  int local_rank =
      0;  ///< LOCAL_RANK (GPU index on its machine); RANK when unset
  std::string master_addr;  ///< MASTER_ADDR: host of rank 0's TCPStore
  int master_port = 0;      ///< MASTER_PORT, in [1, 65535]
  /// TORCHELASTIC_USE_AGENT_STORE=True: torchrun's agent already hosts the
  /// TCPStore at MASTER_ADDR:MASTER_PORT; every rank, rank 0 included,
  /// connects to it as a client, under the key prefix
  /// "/worker/attempt_<TORCHELASTIC_RESTART_COUNT>" (PyTorch's choice).
  bool use_agent_store = false;
  int restart_count = 0;  ///< TORCHELASTIC_RESTART_COUNT (0 when unset)
};

/// Parses the torchrun variables through `getenv` (returns nullptr for an
/// unset variable). Returns nullopt when WORLD_SIZE is unset or 1 (one
/// process). Throws std::invalid_argument naming the variable and its value
/// when one is missing or malformed (RANK outside [0, WORLD_SIZE), a port
/// outside [1, 65535], a non-integer).
std::optional<DistributedEnv> parseDistributedEnv(
    const std::function<const char*(const char*)>& getenv);

/// parseDistributedEnv() over the process environment.
std::optional<DistributedEnv> distributedEnvFromEnvironment();

/// Which c10d process group carries the collectives.
enum class CollectiveBackend { kGloo, kNccl };

/// True when this build can create ProcessGroupNCCL (LibTorch with CUDA and
/// NCCL; never on Debian's CPU-only LibTorch).
bool ncclCompiledIn();

/// Knobs of a process group.
struct DistributedOptions {
  CollectiveBackend backend = CollectiveBackend::kGloo;
  /// Rendezvous and every collective fail after this long.
  std::chrono::milliseconds timeout{std::chrono::minutes(10)};
  /// waitForAll() fails after this long.
  std::chrono::milliseconds wait_timeout{std::chrono::hours(24)};
  /// Gradients and broadcasts are flattened into buckets of at most this
  /// many bytes (one collective per bucket; a larger tensor is its own).
  int64_t bucket_bytes = int64_t{25} << 20;
  /// NCCL only: the GPU of this rank (LOCAL_RANK).
  int device_index = 0;
};

class Distributed {
 public:
  /// Joins the run described by `env`: rank 0 hosts a TCPStore on
  /// MASTER_PORT (all interfaces; not with env.use_agent_store), every rank
  /// connects to MASTER_ADDR:MASTER_PORT and the process group is built over
  /// it. Gloo
  /// uses the interface named by GLOO_SOCKET_IFNAME when set, loopback when
  /// MASTER_ADDR is a loopback address, else the interface of this host's
  /// name. Throws std::runtime_error naming MASTER_ADDR:MASTER_PORT when the
  /// master cannot be reached, the port cannot be bound, or not every rank
  /// joined within options.timeout.
  static std::unique_ptr<Distributed> connect(
      const DistributedEnv& env, const DistributedOptions& options);

  /// A process group over a c10d FileStore at `file` (every rank passes the
  /// same path on a shared filesystem; tests use it with threads). Gloo on
  /// loopback unless GLOO_SOCKET_IFNAME is set.
  static std::unique_ptr<Distributed> overFileStore(
      const std::filesystem::path& file, int rank, int worldSize,
      const DistributedOptions& options);

  ~Distributed();
  Distributed(const Distributed&) = delete;
  Distributed& operator=(const Distributed&) = delete;

  int rank() const;
  int worldSize() const;
  /// Rank 0: the one that writes checkpoints, metrics and logs of the run.
  bool isMaster() const { return rank() == 0; }
  /// "gloo" or "nccl".
  std::string backendName() const;

  /// Returns when every rank called barrier() (fails after the timeout).
  void barrier();

  /// Returns when every rank reached the point named `what` (the same name
  /// on every rank). Polls the store, so it may wait up to
  /// options.wait_timeout (logging every minute how many ranks arrived), and
  /// throws std::runtime_error with the message of a rank that called
  /// abort() meanwhile.
  void waitForAll(const std::string& what);

  /// Tells the other ranks, at their next waitForAll(), that this rank
  /// failed with `message`. Never throws (called on error paths).
  void abort(const std::string& message) noexcept;

  /// Averages the gradients of `parameters` over the ranks, in place:
  /// flattened per dtype and device into buckets of options.bucket_bytes,
  /// summed, divided by the world size. A gradient undefined on every rank
  /// stays undefined (Adam skips it, as in one process); undefined on some
  /// ranks only, it counts as zeros there. Every rank passes the same
  /// parameters in the same order.
  void averageGradients(const std::vector<torch::Tensor>& parameters);

  /// Overwrites `tensors` on every rank with rank `root`'s values (bucketed;
  /// same shapes and order on every rank).
  void broadcastTensors(const std::vector<torch::Tensor>& tensors,
                        int root = 0);

  /// Parameters and buffers of `module` from rank `root`.
  void broadcastModule(torch::nn::Module& module, int root = 0);

  /// The optimizer state (Adam's steps and moments) from rank `root`, via
  /// serializeOptimizer()/loadOptimizerState() (Checkpoint.h).
  void broadcastOptimizer(torch::optim::Optimizer& optimizer, int root = 0);

  /// Rank `root`'s `bytes` on every rank (other ranks' argument is ignored).
  std::string broadcastBytes(const std::string& bytes, int root = 0);

  /// Every rank's `mine`, in rank order, on every rank (lengths may differ;
  /// one all-gather padded to the longest).
  std::vector<std::string> allGatherBytes(const std::string& mine);

  /// Element-wise sum over the ranks (float64). Same length on every rank.
  std::vector<double> allReduceSum(const std::vector<double>& values);

  /// Element-wise maximum over the ranks. Same length on every rank.
  std::vector<int64_t> allReduceMax(const std::vector<int64_t>& values);

  /// Throws std::runtime_error on every rank unless `tensors` are bitwise
  /// identical on every rank, naming the first differing one by `names`
  /// (same size as `tensors`) and `what` (e.g. "after epoch 3"). Compares
  /// two exact integer fingerprints of each tensor's bits.
  void checkIdentical(const std::vector<torch::Tensor>& tensors,
                      const std::vector<std::string>& names,
                      std::string_view what);
  /// checkIdentical() of the parameters and buffers of `module`
  /// (models::namedState()).
  void checkIdentical(const torch::nn::Module& module, std::string_view what);

  /// Runs `step` on this rank, then waits for every rank to finish its own
  /// (waitForAll). When it threw on any rank, every rank throws: a failing
  /// rank rethrows its exception, the others throw std::runtime_error
  /// quoting the lowest failing rank's message, so no rank is left waiting.
  void collectively(const std::string& what, const std::function<void()>& step);

 private:
  struct Impl;
  explicit Distributed(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace vln::train
