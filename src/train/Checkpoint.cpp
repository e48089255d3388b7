#include "train/Checkpoint.h"

#include <ATen/CPUGeneratorImpl.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <charconv>
#include <cstring>

#include "common/Check.h"
#include "common/FileIo.h"
#include "common/Json.h"
#include "common/ZipIntegrity.h"
#include "models/StateDict.h"

namespace vln::train {
namespace {

constexpr const char* kFormat = "vlnce-cpp checkpoint";
constexpr int64_t kVersion = 1;

// opaque bytes travel as uint8 tensors: archive strings are pickled text
torch::Tensor bytesTensor(const std::string& bytes) {
  torch::Tensor t =
      torch::empty({static_cast<int64_t>(bytes.size())}, torch::kUInt8);
  if (!bytes.empty()) std::memcpy(t.data_ptr(), bytes.data(), bytes.size());
  return t;
}

std::string tensorBytes(const torch::Tensor& t) {
  const torch::Tensor c = t.to(torch::kUInt8).contiguous();
  return std::string(static_cast<const char*>(c.data_ptr()),
                     static_cast<size_t>(c.numel()));
}

nlohmann::json progressToJson(const TrainingProgress& p) {
  return {{"checkpoint_index", p.checkpoint_index},
          {"dagger_iteration", p.dagger_iteration},
          {"epoch", p.epoch},
          {"updates", p.updates},
          {"episodes_collected", p.episodes_collected},
          {"stage", p.stage},
          {"best_spl", p.best_spl},
          {"best_checkpoint", p.best_checkpoint},
          {"extra", p.extra}};
}

TrainingProgress progressFromJson(const nlohmann::json& j,
                                  const std::string& source) {
  TrainingProgress p;
  p.checkpoint_index = common::requireField<int>(j, "checkpoint_index", source);
  p.dagger_iteration = common::requireField<int>(j, "dagger_iteration", source);
  p.epoch = common::requireField<int>(j, "epoch", source);
  p.updates = common::requireField<int64_t>(j, "updates", source);
  p.episodes_collected =
      common::requireField<int64_t>(j, "episodes_collected", source);
  p.stage = common::requireField<std::string>(j, "stage", source);
  p.best_spl = common::requireField<double>(j, "best_spl", source);
  p.best_checkpoint = common::requireField<int>(j, "best_checkpoint", source);
  p.extra = common::requireField<nlohmann::json>(j, "extra", source);
  return p;
}

}  // namespace

std::string checkpointFileName(int index) {
  VLN_ASSERT(index >= 0);
  return "ckpt." + std::to_string(index) + ".pth";
}

std::string serializeCheckpoint(const Checkpoint& checkpoint) {
  torch::serialize::OutputArchive archive;
  archive.write("format", c10::IValue(std::string(kFormat)));
  archive.write("version", c10::IValue(kVersion));
  archive.write("config_yaml", c10::IValue(checkpoint.config_yaml));
  archive.write("progress",
                c10::IValue(progressToJson(checkpoint.progress).dump()));
  archive.write("optimizer_state", bytesTensor(checkpoint.optimizer_state),
                true);
  archive.write("rng_state", bytesTensor(checkpoint.rng_state), true);
  // tensor names may contain dots, which archive keys may not: names go in
  // a list and tensors under their position
  nlohmann::json names = nlohmann::json::array();
  torch::serialize::OutputArchive policy;
  for (size_t i = 0; i < checkpoint.policy.size(); ++i) {
    names.push_back(checkpoint.policy[i].first);
    policy.write(
        strCat("t", i),
        checkpoint.policy[i].second.detach().to(torch::kCPU).contiguous(),
        true);
  }
  archive.write("policy_names", c10::IValue(names.dump()));
  archive.write("policy", policy);
  std::string bytes;
  archive.save_to([&](const void* data, size_t size) {
    bytes.append(static_cast<const char*>(data), size);
    return size;
  });
  return bytes;
}

Checkpoint deserializeCheckpoint(std::string_view bytes,
                                 const std::string& source) {
  // LibTorch reads damaged archives without checking their CRCs, and its
  // TorchScript parser can crash on them
  try {
    common::verifyZipIntegrity(bytes, source);
  } catch (const std::runtime_error& error) {
    throw std::runtime_error(strCat("loadCheckpoint(): ", error.what()));
  }
  Checkpoint checkpoint;
  try {
    torch::serialize::InputArchive archive;
    archive.load_from(bytes.data(), bytes.size());
    c10::IValue value;
    VLN_CHECK_IO(archive.try_read("format", value) && value.isString() &&
                     value.toStringRef() == kFormat,
                 "loadCheckpoint(): '", source,
                 "' is not a vlnce-cpp checkpoint");
    archive.read("version", value);
    VLN_CHECK_IO(value.isInt() && value.toInt() == kVersion,
                 "loadCheckpoint(): '", source, "' has checkpoint version ",
                 value.isInt() ? value.toInt() : -1, ", expected ", kVersion);
    archive.read("config_yaml", value);
    checkpoint.config_yaml = value.toStringRef();
    archive.read("progress", value);
    checkpoint.progress =
        progressFromJson(nlohmann::json::parse(value.toStringRef()),
                         strCat(source, " progress"));
    torch::Tensor t;
    archive.read("optimizer_state", t, true);
    checkpoint.optimizer_state = tensorBytes(t);
    archive.read("rng_state", t, true);
    checkpoint.rng_state = tensorBytes(t);
    archive.read("policy_names", value);
    const auto names = nlohmann::json::parse(value.toStringRef());
    torch::serialize::InputArchive policy;
    archive.read("policy", policy);
    for (size_t i = 0; i < names.size(); ++i) {
      torch::Tensor tensor;
      policy.read(strCat("t", i), tensor, true);
      checkpoint.policy.emplace_back(names[i].get<std::string>(), tensor);
    }
  } catch (const c10::Error& error) {
    throw std::runtime_error(strCat("loadCheckpoint(): '", source,
                                    "' is truncated or not a checkpoint: ",
                                    error.what_without_backtrace()));
  } catch (const nlohmann::json::exception& error) {
    throw std::runtime_error(strCat("loadCheckpoint(): '", source,
                                    "' has corrupt metadata: ", error.what()));
  } catch (const std::invalid_argument& error) {
    throw std::runtime_error(strCat("loadCheckpoint(): ", error.what()));
  } catch (const std::runtime_error&) {
    throw;
  } catch (const std::exception& error) {
    // LibTorch's reader lets standard exceptions out of some inconsistent
    // archives (std::out_of_range from a map lookup, found by fuzzing)
    throw std::runtime_error(
        strCat("loadCheckpoint(): '", source,
               "' is not a readable checkpoint: ", error.what()));
  }
  return checkpoint;
}

void saveCheckpoint(const std::filesystem::path& file,
                    const Checkpoint& checkpoint) {
  const std::string bytes = serializeCheckpoint(checkpoint);
  try {
    common::writeFileAtomic(file, bytes);
  } catch (const std::exception& error) {
    throw std::runtime_error(strCat(
        "saveCheckpoint(): cannot write checkpoint '", file.string(), "' (",
        bytes.size(), " bytes; the previous file is intact): ", error.what()));
  }
}

Checkpoint loadCheckpoint(const std::filesystem::path& file) {
  VLN_CHECK_IO(std::filesystem::is_regular_file(file), "loadCheckpoint(): '",
               file.string(), "' does not exist");
  const std::string bytes = common::readFile(file);
  return deserializeCheckpoint(bytes, file.string());
}

std::optional<int> checkpointIndex(const std::filesystem::path& file) {
  const std::string name = file.filename().string();
  constexpr std::string_view prefix = "ckpt.";
  constexpr std::string_view suffix = ".pth";
  if (name.size() <= prefix.size() + suffix.size() ||
      !name.starts_with(prefix) || !name.ends_with(suffix))
    return std::nullopt;
  const std::string_view digits(name.data() + prefix.size(),
                                name.size() - prefix.size() - suffix.size());
  int index = -1;
  auto [end, ec] =
      std::from_chars(digits.data(), digits.data() + digits.size(), index);
  if (ec != std::errc() || end != digits.data() + digits.size() || index < 0)
    return std::nullopt;
  return index;
}

std::vector<std::filesystem::path> listCheckpoints(
    const std::filesystem::path& dir) {
  std::vector<std::pair<int, std::filesystem::path>> found;
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return {};
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    if (auto index = checkpointIndex(entry.path());
        index && entry.is_regular_file())
      found.emplace_back(*index, entry.path());
  std::sort(found.begin(), found.end());
  std::vector<std::filesystem::path> files;
  for (auto& [index, path] : found) files.push_back(std::move(path));
  return files;
}

}  // namespace vln::train

namespace vln::train {

// Adam's state in a layout of our own, keyed by the position of each
// parameter (group g, parameter i) instead of LibTorch's own
// Optimizer::save(), which keys it by the address of the parameter's
// TensorImpl and in hash-map order: two identical runs then wrote
// different bytes, and checkpoints could not be compared for determinism.
namespace {

constexpr int64_t kAdamStateFormat = 1;

std::string stateKey(size_t group, size_t param, const char* what) {
  return strCat("g", group, "/p", param, "/", what);
}

std::string implKey(const torch::Tensor& param) {
  return c10::guts::to_string(param.unsafeGetTensorImpl());
}

}  // namespace

std::string serializeOptimizer(const torch::optim::Optimizer& optimizer) {
  torch::serialize::OutputArchive archive;
  archive.write("vln_adam_format", torch::tensor(kAdamStateFormat));
  const auto& groups = optimizer.param_groups();
  archive.write("groups", torch::tensor(static_cast<int64_t>(groups.size())));
  for (size_t g = 0; g < groups.size(); ++g) {
    const auto* options =
        dynamic_cast<const torch::optim::AdamOptions*>(&groups[g].options());
    VLN_CHECK_ARG(options != nullptr,
                  "serializeOptimizer(): only Adam is supported");
    archive.write(
        strCat("g", g, "/options"),
        torch::tensor({options->lr(), std::get<0>(options->betas()),
                       std::get<1>(options->betas()), options->eps(),
                       options->weight_decay(), options->amsgrad() ? 1.0 : 0.0},
                      torch::kFloat64));
    const auto& params = groups[g].params();
    archive.write(strCat("g", g, "/params"),
                  torch::tensor(static_cast<int64_t>(params.size())));
    for (size_t i = 0; i < params.size(); ++i) {
      auto it = optimizer.state().find(implKey(params[i]));
      if (it == optimizer.state().end()) continue;  // never stepped
      const auto& state =
          static_cast<const torch::optim::AdamParamState&>(*it->second);
      archive.write(stateKey(g, i, "step"), torch::tensor(state.step()));
      archive.write(stateKey(g, i, "exp_avg"), state.exp_avg());
      archive.write(stateKey(g, i, "exp_avg_sq"), state.exp_avg_sq());
      if (state.max_exp_avg_sq().defined())
        archive.write(stateKey(g, i, "max_exp_avg_sq"), state.max_exp_avg_sq());
    }
  }
  std::string bytes;
  archive.save_to([&](const void* data, size_t size) {
    bytes.append(static_cast<const char*>(data), size);
    return size;
  });
  return bytes;
}

void setAdamLearningRate(torch::optim::Optimizer& optimizer, double lr) {
  for (auto& group : optimizer.param_groups()) {
    auto* options = dynamic_cast<torch::optim::AdamOptions*>(&group.options());
    VLN_CHECK_ARG(options != nullptr,
                  "setAdamLearningRate(): only Adam is supported");
    options->lr(lr);
  }
}

double adamLearningRate(const torch::optim::Optimizer& optimizer) {
  VLN_CHECK_ARG(!optimizer.param_groups().empty(),
                "adamLearningRate(): the optimizer has no parameters");
  const auto* options = dynamic_cast<const torch::optim::AdamOptions*>(
      &optimizer.param_groups().front().options());
  VLN_CHECK_ARG(options != nullptr,
                "adamLearningRate(): only Adam is supported");
  return options->lr();
}

void loadOptimizerState(torch::optim::Optimizer& optimizer,
                        std::string_view bytes, const std::string& source) {
  try {
    torch::serialize::InputArchive archive;
    archive.load_from(bytes.data(), bytes.size());
    torch::Tensor format;
    if (!archive.try_read("vln_adam_format", format)) {
      optimizer.load(archive);  // LibTorch's own layout (older checkpoints)
      return;
    }
    VLN_CHECK_ARG(format.item<int64_t>() == kAdamStateFormat,
                  "loadOptimizerState(): '", source,
                  "' has optimizer state format ", format.item<int64_t>(),
                  ", this build reads ", kAdamStateFormat);
    torch::Tensor count;
    archive.read("groups", count);
    auto& groups = optimizer.param_groups();
    VLN_CHECK_ARG(count.item<int64_t>() == static_cast<int64_t>(groups.size()),
                  "loadOptimizerState(): the optimizer state of '", source,
                  "' has ", count.item<int64_t>(),
                  " parameter groups, the optimizer ", groups.size());
    std::vector<std::string> mismatches;
    for (size_t g = 0; g < groups.size(); ++g) {
      auto* options =
          dynamic_cast<torch::optim::AdamOptions*>(&groups[g].options());
      VLN_CHECK_ARG(options != nullptr,
                    "loadOptimizerState(): only Adam is supported");
      torch::Tensor o;
      archive.read(strCat("g", g, "/options"), o);
      const auto v = o.accessor<double, 1>();
      options->lr(v[0])
          .betas({v[1], v[2]})
          .eps(v[3])
          .weight_decay(v[4])
          .amsgrad(v[5] != 0.0);
      archive.read(strCat("g", g, "/params"), count);
      const auto& params = groups[g].params();
      VLN_CHECK_ARG(
          count.item<int64_t>() == static_cast<int64_t>(params.size()),
          "loadOptimizerState(): the optimizer state of '", source, "' is for ",
          count.item<int64_t>(), " parameters, the policy has ", params.size());
      for (size_t i = 0; i < params.size(); ++i) {
        torch::Tensor step, expAvg, expAvgSq, maxExpAvgSq;
        if (!archive.try_read(stateKey(g, i, "step"), step)) continue;
        archive.read(stateKey(g, i, "exp_avg"), expAvg);
        archive.read(stateKey(g, i, "exp_avg_sq"), expAvgSq);
        if (!expAvg.sizes().equals(params[i].sizes()) ||
            !expAvgSq.sizes().equals(params[i].sizes())) {
          mismatches.push_back(strCat("parameter ", i, " of group ", g,
                                      ": state ", expAvg.sizes(),
                                      ", parameter ", params[i].sizes()));
          continue;
        }
        auto state = std::make_unique<torch::optim::AdamParamState>();
        state->step(step.item<int64_t>());
        state->exp_avg(expAvg.to(params[i].device()));
        state->exp_avg_sq(expAvgSq.to(params[i].device()));
        if (archive.try_read(stateKey(g, i, "max_exp_avg_sq"), maxExpAvgSq))
          state->max_exp_avg_sq(maxExpAvgSq.to(params[i].device()));
        optimizer.state()[implKey(params[i])] = std::move(state);
      }
    }
    if (!mismatches.empty()) {
      std::string list;
      for (const auto& m : mismatches) list += "\n  " + m;
      throw std::invalid_argument(
          strCat("loadOptimizerState(): the optimizer state of '", source,
                 "' does not fit this policy:", list));
    }
  } catch (const std::invalid_argument& error) {
    // a checkpoint that does not fit is bad data, not a bad call
    throw std::runtime_error(error.what());
  } catch (const c10::Error& error) {
    throw std::runtime_error(
        strCat("loadOptimizerState(): the optimizer state of '", source,
               "' does not fit this policy: ", error.what_without_backtrace()));
  }
}

// ---------------------------------------------------------------------------
// finding and restoring

std::filesystem::path bestOrLatestCheckpoint(
    const std::filesystem::path& runDir) {
  const std::filesystem::path dir = runDir / "checkpoints";
  const std::filesystem::path best = dir / "best.json";
  if (std::filesystem::exists(best)) {
    const auto json = common::readJsonFile(best);
    const std::filesystem::path file =
        dir /
        common::requireField<std::string>(json, "checkpoint", best.string());
    VLN_CHECK_IO(std::filesystem::exists(file), "train: ", best.string(),
                 " names '", file.string(), "', which does not exist");
    return file;
  }
  const auto all = listCheckpoints(dir);
  VLN_CHECK_IO(!all.empty(), "train: '", dir.string(), "' holds no checkpoint");
  return all.back();
}

// policy tensors from one of our checkpoints, from a run directory or from
// a TorchScript tensor file
models::NamedTensors readPolicyWeights(const std::filesystem::path& given) {
  std::filesystem::path file = given;
  if (std::filesystem::is_directory(given)) {
    file = bestOrLatestCheckpoint(given);
    spdlog::info("trainer.init_checkpoint: run directory {} -> {}",
                 given.string(), file.string());
  }
  try {
    return loadCheckpoint(file).policy;
  } catch (const std::runtime_error& checkpointError) {
    try {
      return models::readTensorFile(file);
    } catch (const std::runtime_error&) {
      throw std::runtime_error("trainer.init_checkpoint: '" + file.string() +
                               "' is neither a checkpoint nor a tensor file: " +
                               checkpointError.what());
    }
  }
}

Checkpoint trainingCheckpoint(const std::string& configYaml,
                              const torch::nn::Module& policy,
                              const torch::optim::Optimizer& optimizer,
                              const TrainingProgress& progress) {
  Checkpoint ckpt;
  ckpt.config_yaml = configYaml;
  ckpt.policy = models::namedState(policy);
  ckpt.optimizer_state = serializeOptimizer(optimizer);
  ckpt.progress = progress;
  ckpt.rng_state = captureRngState();
  return ckpt;
}

std::string captureRngState() {
  auto generator = at::detail::getDefaultCPUGenerator();
  std::lock_guard<std::mutex> lock(generator.mutex());
  const torch::Tensor state = generator.get_state().contiguous();
  return std::string(static_cast<const char*>(state.data_ptr()),
                     static_cast<size_t>(state.numel()));
}

void restoreRngState(const std::string& bytes, const std::string& source) {
  if (bytes.empty()) return;
  auto generator = at::detail::getDefaultCPUGenerator();
  std::lock_guard<std::mutex> lock(generator.mutex());
  torch::Tensor state =
      torch::empty({static_cast<int64_t>(bytes.size())}, torch::kUInt8);
  std::memcpy(state.data_ptr(), bytes.data(), bytes.size());
  try {
    generator.set_state(state);
  } catch (const c10::Error& error) {
    throw std::runtime_error(
        "train --resume: '" + source +
        "' holds an invalid RNG state: " + error.what_without_backtrace());
  }
}

}  // namespace vln::train
