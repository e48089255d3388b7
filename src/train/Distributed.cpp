#include "train/Distributed.h"

// ProcessGroupGloo.hpp and ProcessGroupNCCL.hpp compile only under these
// guards (TorchConfig.cmake usually defines them); Debian's libtorch_cpu
// exports the Gloo process group, a CUDA build of LibTorch also the NCCL one.
#ifndef USE_C10D_GLOO
#define USE_C10D_GLOO 1
#endif
#if VLN_WITH_NCCL
#ifndef USE_C10D_NCCL
#define USE_C10D_NCCL 1
#endif
#include <torch/csrc/distributed/c10d/ProcessGroupNCCL.hpp>
#endif
#include <spdlog/spdlog.h>
#include <torch/csrc/distributed/c10d/FileStore.hpp>
#include <torch/csrc/distributed/c10d/PrefixStore.hpp>
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <cstring>
#include <thread>

#include "common/Check.h"
#include "common/Progress.h"
#include "train/Checkpoint.h"
#include "models/StateDict.h"

namespace vln::train {
namespace {

constexpr const char* kAbortKey = "vln/abort";

// an integer environment variable in [lo, hi]; `text` is its value
int parseIntVariable(const char* name, const char* text, int lo, int hi) {
  const std::string value = text;
  int parsed = 0;
  const auto [end, ec] =
      std::from_chars(value.data(), value.data() + value.size(), parsed);
  VLN_CHECK_ARG(
      ec == std::errc() && end == value.data() + value.size() && !value.empty(),
      "distributed training: environment variable ", name, "='", value,
      "' is not an integer");
  VLN_CHECK_ARG(parsed >= lo && parsed <= hi,
                "distributed training: environment variable ", name, "=",
                parsed, " is outside [", lo, ", ", hi, "]");
  return parsed;
}

bool isLoopback(const std::string& host) {
  return host.rfind("127.", 0) == 0 || host == "localhost" || host == "::1";
}

std::string errorText(const std::exception& error) {
  if (const auto* c10 = dynamic_cast<const c10::Error*>(&error))
    return c10->what_without_backtrace();
  return error.what();
}

double seconds(std::chrono::milliseconds ms) {
  return static_cast<double>(ms.count()) / 1000.0;
}

// gloo's transport device: GLOO_SOCKET_IFNAME, loopback for a loopback
// master, else the address this host's name resolves to
std::shared_ptr<::gloo::transport::Device> glooDevice(
    const std::string& masterAddr) {
  if (const char* ifname = std::getenv("GLOO_SOCKET_IFNAME");
      ifname != nullptr && *ifname != '\0')
    return c10d::ProcessGroupGloo::createDeviceForInterface(ifname);
  if (masterAddr.empty() || isLoopback(masterAddr))
    return c10d::ProcessGroupGloo::createDeviceForHostname("127.0.0.1");
  return c10d::ProcessGroupGloo::createDefaultDevice();
}

// the bits of a tensor as int64 values, so that sums are exact and do not
// depend on the order of summation
torch::Tensor bitsOf(const torch::Tensor& tensor) {
  torch::Tensor t = tensor.detach().to(torch::kCPU).contiguous().reshape(-1);
  switch (t.scalar_type()) {
    case torch::kFloat32:
      return t.view(torch::kInt32).to(torch::kInt64);
    case torch::kFloat64:
      return t.view(torch::kInt64);
    case torch::kFloat16:
    case torch::kBFloat16:
      return t.view(torch::kInt16).to(torch::kInt64);
    default:
      return t.to(torch::kInt64);
  }
}

}  // namespace

// ---------------------------------------------------------------------------
// environment

std::optional<DistributedEnv> parseDistributedEnv(
    const std::function<const char*(const char*)>& getenv) {
  const char* worldText = getenv("WORLD_SIZE");
  if (worldText == nullptr || *worldText == '\0') return std::nullopt;
  DistributedEnv env;
  env.world_size = parseIntVariable("WORLD_SIZE", worldText, 1, 1 << 20);
  if (env.world_size == 1) return std::nullopt;
  auto required = [&](const char* name) {
    const char* value = getenv(name);
    VLN_CHECK_ARG(value != nullptr && *value != '\0',
                  "distributed training: WORLD_SIZE=", env.world_size,
                  " but environment variable ", name,
                  " is not set (set RANK, MASTER_ADDR and MASTER_PORT as "
                  "torchrun does, or unset WORLD_SIZE for one process)");
    return value;
  };
  env.rank = parseIntVariable("RANK", required("RANK"), 0, env.world_size - 1);
  env.master_addr = required("MASTER_ADDR");
  env.master_port =
      parseIntVariable("MASTER_PORT", required("MASTER_PORT"), 1, 65535);
  const char* local = getenv("LOCAL_RANK");
  env.local_rank = local != nullptr && *local != '\0'
                       ? parseIntVariable("LOCAL_RANK", local, 0, 1 << 20)
                       : env.rank;
  // torchrun's static rendezvous: its agent hosts the store on MASTER_PORT
  const char* agentStore = getenv("TORCHELASTIC_USE_AGENT_STORE");
  env.use_agent_store =
      agentStore != nullptr && std::string_view(agentStore) == "True";
  const char* restarts = getenv("TORCHELASTIC_RESTART_COUNT");
  if (restarts != nullptr && *restarts != '\0')
    env.restart_count =
        parseIntVariable("TORCHELASTIC_RESTART_COUNT", restarts, 0, 1 << 30);
  return env;
}

std::optional<DistributedEnv> distributedEnvFromEnvironment() {
  return parseDistributedEnv(
      [](const char* name) { return std::getenv(name); });
}

bool ncclCompiledIn() {
#if VLN_WITH_NCCL
  return true;
#else
  return false;
#endif
}

// ---------------------------------------------------------------------------
// the process group

struct Distributed::Impl {
  int rank = 0;
  int world = 1;
  DistributedOptions options;
  std::string endpoint;  ///< where the store lives, for messages
  c10::intrusive_ptr<c10d::Store> store;
  c10::intrusive_ptr<c10d::ProcessGroup> group;
  torch::Device commDevice{torch::kCPU};
  int64_t waitGeneration = 0;

  // builds the process group over `store` (rendezvous of every rank)
  void createGroup(const std::string& masterAddr) {
    auto groupStore = c10::make_intrusive<c10d::PrefixStore>("pg", store);
    try {
      if (options.backend == CollectiveBackend::kNccl) {
#if VLN_WITH_NCCL
        auto o = c10d::ProcessGroupNCCL::Options::create();
        o->timeout = options.timeout;
        group = c10::make_intrusive<c10d::ProcessGroupNCCL>(groupStore, rank,
                                                            world, o);
        commDevice = torch::Device(torch::kCUDA,
                                   static_cast<int8_t>(options.device_index));
#else
        throw std::invalid_argument(
            "Distributed: the NCCL backend was requested but this LibTorch "
            "build has no NCCL (trainer.distributed_backend: use gloo)");
#endif
      } else {
        auto o = c10d::ProcessGroupGloo::Options::create(options.timeout);
        o->devices.push_back(glooDevice(masterAddr));
        group = c10::make_intrusive<c10d::ProcessGroupGloo>(groupStore, rank,
                                                            world, o);
      }
    } catch (const std::invalid_argument&) {
      throw;
    } catch (const std::exception& error) {
      throw std::runtime_error(strCat(
          "Distributed: rank ", rank,
          " could not form the process group of WORLD_SIZE=", world,
          " ranks through ", endpoint, " within ", seconds(options.timeout),
          " s (trainer.distributed_timeout_s; did every rank start, with the "
          "same WORLD_SIZE?): ",
          errorText(error)));
    }
  }

  // runs one collective and waits for it, turning c10d/gloo errors into
  // messages that name this rank and the operation
  template <class Start>
  void run(const char* what, Start start) {
    try {
      c10::intrusive_ptr<c10d::Work> work = start();
      work->wait();
    } catch (const std::exception& error) {
      throw std::runtime_error(
          strCat("Distributed: rank ", rank, " of ", world, ": ", what,
                 " failed (another rank stopped, or it took longer than "
                 "trainer.distributed_timeout_s = ",
                 seconds(options.timeout),
                 " s; see the other ranks' logs): ", errorText(error)));
    }
  }

  void allReduce(torch::Tensor& tensor, c10d::ReduceOp op, const char* what) {
    std::vector<torch::Tensor> tensors = {tensor};
    c10d::AllreduceOptions o;
    o.reduceOp = op;
    run(what, [&] { return group->allreduce(tensors, o); });
  }

  // all-reduces `values` with `op` as one tensor of `dtype` on the
  // communication device
  template <class T>
  std::vector<T> allReduceValues(const std::vector<T>& values,
                                 torch::ScalarType dtype, c10d::ReduceOp op,
                                 const char* what) {
    if (values.empty()) return {};
    torch::Tensor t = torch::tensor(values, dtype).to(commDevice);
    allReduce(t, op, what);
    t = t.to(torch::kCPU).contiguous();
    return std::vector<T>(t.data_ptr<T>(), t.data_ptr<T>() + t.numel());
  }

  void broadcast(torch::Tensor& tensor, int root, const char* what) {
    std::vector<torch::Tensor> tensors = {tensor};
    c10d::BroadcastOptions o;
    o.rootRank = root;
    run(what, [&] { return group->broadcast(tensors, o); });
  }

  // calls `collective` on flattened buckets of consecutive tensors of one
  // dtype and device (at most bucket_bytes, or one larger tensor), then
  // copies the results back into the tensors
  void forEachBucket(const std::vector<torch::Tensor>& tensors,
                     const std::function<void(torch::Tensor&)>& collective) {
    torch::NoGradGuard noGrad;
    size_t begin = 0;
    while (begin < tensors.size()) {
      const torch::Tensor& first = tensors[begin];
      size_t end = begin;
      int64_t bytes = 0;
      while (end < tensors.size() &&
             tensors[end].scalar_type() == first.scalar_type() &&
             tensors[end].device() == first.device()) {
        const int64_t size = tensors[end].numel() *
                             static_cast<int64_t>(tensors[end].element_size());
        if (end > begin && bytes + size > options.bucket_bytes) break;
        bytes += size;
        ++end;
      }
      std::vector<torch::Tensor> parts;
      for (size_t i = begin; i < end; ++i)
        parts.push_back(tensors[i].reshape(-1));
      torch::Tensor flat = torch::cat(parts).to(commDevice);
      collective(flat);
      int64_t offset = 0;
      for (size_t i = begin; i < end; ++i) {
        const int64_t n = tensors[i].numel();
        torch::Tensor target = tensors[i];
        target.copy_(flat.slice(0, offset, offset + n).view_as(target));
        offset += n;
      }
      begin = end;
    }
  }
};

Distributed::Distributed(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Distributed::~Distributed() = default;

std::unique_ptr<Distributed> Distributed::connect(
    const DistributedEnv& env, const DistributedOptions& options) {
  VLN_CHECK_ARG(
      env.world_size >= 2 && env.rank >= 0 && env.rank < env.world_size,
      "Distributed::connect(): RANK=", env.rank,
      " must be in [0, WORLD_SIZE=", env.world_size, ") with WORLD_SIZE >= 2");
  auto impl = std::make_unique<Impl>();
  impl->rank = env.rank;
  impl->world = env.world_size;
  impl->options = options;
  impl->endpoint = strCat("MASTER_ADDR:MASTER_PORT = ", env.master_addr, ":",
                          env.master_port);
  // rank 0 hosts the store (unless torchrun's agent does); everyone, rank
  // 0 included, connects to it
  c10d::TCPStoreOptions storeOptions;
  storeOptions.port = static_cast<uint16_t>(env.master_port);
  storeOptions.isServer = env.rank == 0 && !env.use_agent_store;
  storeOptions.numWorkers = static_cast<size_t>(env.world_size);
  storeOptions.waitWorkers = false;  // the process group waits for them
  storeOptions.timeout = options.timeout;
  try {
    impl->store =
        c10::make_intrusive<c10d::TCPStore>(env.master_addr, storeOptions);
    // the agent's store outlives a restarted attempt: keys of this one only
    if (env.use_agent_store)
      impl->store = c10::make_intrusive<c10d::PrefixStore>(
          strCat("/worker/attempt_", env.restart_count), impl->store);
  } catch (const std::exception& error) {
    if (storeOptions.isServer)
      throw std::runtime_error(strCat(
          "Distributed::connect(): rank 0 could not host the rendezvous "
          "store at ",
          impl->endpoint,
          " (is MASTER_PORT in use, or MASTER_ADDR not an address of this "
          "machine?): ",
          errorText(error)));
    throw std::runtime_error(strCat(
        "Distributed::connect(): rank ", env.rank,
        " could not reach the master at ", impl->endpoint, " within ",
        seconds(options.timeout),
        " s (trainer.distributed_timeout_s; is rank 0 running, and the port "
        "open from this machine?): ",
        errorText(error)));
  }
  impl->createGroup(env.master_addr);
  spdlog::info("distributed: rank {} of {} joined through {}{} ({})", env.rank,
               env.world_size, impl->endpoint,
               env.use_agent_store ? " (torchrun's store)" : "",
               options.backend == CollectiveBackend::kNccl ? "nccl" : "gloo");
  return std::unique_ptr<Distributed>(new Distributed(std::move(impl)));
}

std::unique_ptr<Distributed> Distributed::overFileStore(
    const std::filesystem::path& file, int rank, int worldSize,
    const DistributedOptions& options) {
  VLN_CHECK_ARG(worldSize >= 1 && rank >= 0 && rank < worldSize,
                "Distributed::overFileStore(): rank ", rank,
                " must be in [0, worldSize = ", worldSize, ")");
  auto impl = std::make_unique<Impl>();
  impl->rank = rank;
  impl->world = worldSize;
  impl->options = options;
  impl->endpoint = "the file store '" + file.string() + "'";
  try {
    impl->store =
        c10::make_intrusive<c10d::FileStore>(file.string(), worldSize);
    impl->store->setTimeout(options.timeout);
  } catch (const std::exception& error) {
    throw std::runtime_error(
        strCat("Distributed::overFileStore(): cannot open '", file.string(),
               "': ", errorText(error)));
  }
  impl->createGroup("");
  return std::unique_ptr<Distributed>(new Distributed(std::move(impl)));
}

int Distributed::rank() const { return impl_->rank; }

int Distributed::worldSize() const { return impl_->world; }

std::string Distributed::backendName() const {
  return impl_->options.backend == CollectiveBackend::kNccl ? "nccl" : "gloo";
}

void Distributed::barrier() {
  impl_->run("barrier", [&] { return impl_->group->barrier(); });
}

void Distributed::waitForAll(const std::string& what) {
  Impl& d = *impl_;
  const std::string key = strCat("vln/wait/", d.waitGeneration++);
  const std::string allKey = key + "/all";
  common::Stopwatch clock;
  double nextLog = 60.0;
  auto storeFailed = [&](const std::exception& error) {
    return std::runtime_error(
        strCat("Distributed: rank ", d.rank, " lost the rendezvous store at ",
               d.endpoint, " while waiting for every rank at '", what,
               "' (rank 0 hosts it: did it stop?): ", errorText(error)));
  };
  try {
    // the last rank to arrive marks the point as reached by all
    if (d.store->add(key, 1) == d.world)
      d.store->set(allKey, std::vector<uint8_t>{1});
    auto pause = std::chrono::microseconds(200);
    while (!d.store->check({allKey})) {
      if (d.store->check({kAbortKey})) {
        const std::vector<uint8_t> message = d.store->get(kAbortKey);
        throw std::runtime_error(
            strCat("Distributed: rank ", d.rank,
                   " stopped while waiting for every rank at '", what,
                   "' because ", std::string(message.begin(), message.end())));
      }
      const double waited = clock.seconds();
      if (waited > seconds(d.options.wait_timeout))
        throw std::runtime_error(
            strCat("Distributed: rank ", d.rank, " waited ",
                   static_cast<int64_t>(waited), " s for every rank at '", what,
                   "': ", d.store->add(key, 0), " of ", d.world,
                   " arrived (trainer.distributed_wait_s = ",
                   seconds(d.options.wait_timeout), ")"));
      if (waited > nextLog) {
        spdlog::info(
            "rank {}: waiting for the other ranks at '{}' ({} of {} "
            "arrived, {:.0f} s)",
            d.rank, what, d.store->add(key, 0), d.world, waited);
        nextLog += 60.0;
      }
      std::this_thread::sleep_for(pause);
      pause = std::min(pause * 2, std::chrono::microseconds(200000));
    }
  } catch (const c10::Error& error) {
    throw storeFailed(error);
  }
  // nobody leaves (rank 0 would take the store with it) before all saw it
  barrier();
}

void Distributed::abort(const std::string& message) noexcept {
  try {
    const std::string text = strCat("rank ", impl_->rank, " failed: ", message);
    impl_->store->set(kAbortKey,
                      std::vector<uint8_t>(text.begin(), text.end()));
  } catch (...) {
    // the store may be gone already (rank 0 stopped): nothing left to tell
  }
}

void Distributed::averageGradients(
    const std::vector<torch::Tensor>& parameters) {
  Impl& d = *impl_;
  // which gradients exist on how many ranks
  std::vector<double> defined(parameters.size());
  for (size_t i = 0; i < parameters.size(); ++i)
    defined[i] = parameters[i].grad().defined() ? 1.0 : 0.0;
  const std::vector<double> counts = allReduceSum(defined);
  std::vector<torch::Tensor> grads;
  for (size_t i = 0; i < parameters.size(); ++i) {
    if (counts[i] == 0.0) continue;
    torch::Tensor p = parameters[i];
    if (!p.grad().defined()) p.mutable_grad() = torch::zeros_like(p);
    grads.push_back(p.grad());
  }
  const double world = static_cast<double>(d.world);
  d.forEachBucket(grads, [&](torch::Tensor& flat) {
    d.allReduce(flat, c10d::ReduceOp::SUM, "the gradient all-reduce");
    flat.div_(world);
  });
}

void Distributed::broadcastTensors(const std::vector<torch::Tensor>& tensors,
                                   int root) {
  Impl& d = *impl_;
  d.forEachBucket(tensors, [&](torch::Tensor& flat) {
    d.broadcast(flat, root, "the broadcast of tensors");
  });
}

void Distributed::broadcastModule(torch::nn::Module& module, int root) {
  std::vector<torch::Tensor> tensors = module.parameters();
  for (const torch::Tensor& b : module.buffers()) tensors.push_back(b);
  broadcastTensors(tensors, root);
}

void Distributed::broadcastOptimizer(torch::optim::Optimizer& optimizer,
                                     int root) {
  const std::string bytes = broadcastBytes(
      rank() == root ? serializeOptimizer(optimizer) : std::string(), root);
  if (rank() != root)
    loadOptimizerState(optimizer, bytes,
                       strCat("the optimizer state broadcast by rank ", root));
}

std::string Distributed::broadcastBytes(const std::string& bytes, int root) {
  Impl& d = *impl_;
  VLN_ASSERT(root >= 0 && root < d.world);
  torch::Tensor size =
      torch::full({1}, d.rank == root ? static_cast<int64_t>(bytes.size()) : 0,
                  torch::kInt64)
          .to(d.commDevice);
  d.broadcast(size, root, "the broadcast of a byte string's size");
  const int64_t n = size.to(torch::kCPU).item<int64_t>();
  if (n == 0) return {};
  torch::Tensor data = torch::empty({n}, torch::kUInt8);
  if (d.rank == root) std::memcpy(data.data_ptr(), bytes.data(), bytes.size());
  data = data.to(d.commDevice);
  d.broadcast(data, root, "the broadcast of a byte string");
  data = data.to(torch::kCPU).contiguous();
  return std::string(static_cast<const char*>(data.data_ptr()),
                     static_cast<size_t>(n));
}

std::vector<std::string> Distributed::allGatherBytes(const std::string& mine) {
  Impl& d = *impl_;
  // every rank's length (each rank fills its own entry), then the bytes
  // padded to the longest: c10d's all-gather takes equal sizes
  std::vector<int64_t> sizes(static_cast<size_t>(d.world), 0);
  sizes[static_cast<size_t>(d.rank)] = static_cast<int64_t>(mine.size());
  sizes = allReduceMax(sizes);
  const int64_t longest = *std::max_element(sizes.begin(), sizes.end());
  std::vector<std::string> all(static_cast<size_t>(d.world));
  if (longest == 0) return all;
  torch::Tensor padded = torch::zeros({longest}, torch::kUInt8);
  std::memcpy(padded.data_ptr(), mine.data(), mine.size());
  std::vector<torch::Tensor> input = {padded.to(d.commDevice)};
  std::vector<std::vector<torch::Tensor>> output(1);
  for (int r = 0; r < d.world; ++r)
    output[0].push_back(torch::empty({longest}, input[0].options()));
  d.run("the all-gather of byte strings",
        [&] { return d.group->allgather(output, input); });
  for (int r = 0; r < d.world; ++r) {
    const torch::Tensor bytes =
        output[0][static_cast<size_t>(r)].to(torch::kCPU).contiguous();
    all[static_cast<size_t>(r)].assign(
        static_cast<const char*>(bytes.data_ptr()),
        static_cast<size_t>(sizes[static_cast<size_t>(r)]));
  }
  return all;
}

std::vector<double> Distributed::allReduceSum(
    const std::vector<double>& values) {
  return impl_->allReduceValues(values, torch::kFloat64, c10d::ReduceOp::SUM,
                                "the all-reduce of metrics");
}

std::vector<int64_t> Distributed::allReduceMax(
    const std::vector<int64_t>& values) {
  return impl_->allReduceValues(values, torch::kInt64, c10d::ReduceOp::MAX,
                                "the all-reduce (max) of counters");
}

void Distributed::checkIdentical(const torch::nn::Module& module,
                                 std::string_view what) {
  std::vector<torch::Tensor> tensors;
  std::vector<std::string> names;
  for (const auto& [name, tensor] : models::namedState(module)) {
    names.push_back(name);
    tensors.push_back(tensor);
  }
  checkIdentical(tensors, names, what);
}

void Distributed::checkIdentical(const std::vector<torch::Tensor>& tensors,
                                 const std::vector<std::string>& names,
                                 std::string_view what) {
  VLN_ASSERT(names.size() == tensors.size());
  // two exact fingerprints per tensor and their complements: max over the
  // ranks of ~f is ~(min of f), so one max-reduction yields both extremes
  const size_t n = tensors.size();
  std::vector<int64_t> values(4 * n);
  for (size_t i = 0; i < n; ++i) {
    const torch::Tensor bits = bitsOf(tensors[i]);
    const torch::Tensor weights =
        torch::arange(bits.numel(), torch::kInt64).remainder(61).add_(1);
    const int64_t f1 = bits.sum().item<int64_t>();
    const int64_t f2 = (bits * weights).sum().item<int64_t>();
    values[4 * i] = f1;
    values[4 * i + 1] = f2;
    values[4 * i + 2] = ~f1;
    values[4 * i + 3] = ~f2;
  }
  const std::vector<int64_t> reduced = allReduceMax(values);
  for (size_t i = 0; i < n; ++i) {
    const bool same = reduced[4 * i] == ~reduced[4 * i + 2] &&
                      reduced[4 * i + 1] == ~reduced[4 * i + 3];
    VLN_CHECK_IO(same, "Distributed: the ranks' copies of '", names[i],
                 "' differ ", what,
                 " (they must stay bitwise identical; this rank's ", rank(),
                 " fingerprint ", values[4 * i],
                 "; ranks use different torch_threads, LibTorch builds or "
                 "CPUs?)");
  }
}

void Distributed::collectively(const std::string& what,
                               const std::function<void()>& step) {
  std::exception_ptr error;
  std::string message;
  try {
    step();
  } catch (const std::exception& e) {
    error = std::current_exception();
    message = e.what();
  }
  waitForAll(what);
  std::vector<int64_t> failed(static_cast<size_t>(worldSize()), 0);
  failed[static_cast<size_t>(rank())] = error ? 1 : 0;
  failed = allReduceMax(failed);
  const auto first = std::find(failed.begin(), failed.end(), int64_t{1});
  if (first == failed.end()) return;
  const int root = static_cast<int>(first - failed.begin());
  const std::string firstMessage = broadcastBytes(message, root);
  if (error) std::rethrow_exception(error);
  throw std::runtime_error(
      strCat("rank ", root, " failed during ", what, ": ", firstMessage));
}

}  // namespace vln::train
