#pragma once
// Named tensors of a module (its "state": parameters and buffers, dotted
// names as in PyTorch's state_dict) and the files that hold them. Every
// weight file this project reads or writes is a TorchScript archive whose
// named parameters and buffers are the tensors, so both C++
// (torch::jit::load) and Python (torch.jit.load) open it without this
// project. Loading is strict: a missing, unexpected or shape-mismatched
// tensor is an error that lists every offender with its name and shape.

#include <torch/torch.h>

#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace vln::models {

/// Ordered (name, tensor) pairs, names dotted ("layer1.0.conv1.weight").
using NamedTensors = std::vector<std::pair<std::string, torch::Tensor>>;

/// Every parameter then every buffer of `module` (recursively), by dotted
/// name. Tensors are shared with the module, not copied.
NamedTensors namedState(const torch::nn::Module& module);

/// Copies `tensors` into `module`'s parameters and buffers by name (with
/// dtype/device conversion). Throws std::invalid_argument, naming `source`
/// and listing every missing name (with the expected shape), every
/// unexpected name (with its shape) and every shape mismatch (both shapes),
/// when the names or shapes are not exactly those of namedState(module);
/// the module is left unchanged then.
void loadStateStrict(torch::nn::Module& module, const NamedTensors& tensors,
                     std::string_view source = "<tensors>");

/// Keeps the tensors whose name starts with `prefix`, with the prefix removed
/// ("visual_encoder." turns "visual_encoder.backbone.conv1.0.weight" into
/// "backbone.conv1.0.weight").
NamedTensors stripPrefix(const NamedTensors& tensors, std::string_view prefix);

/// The named parameters and buffers of the TorchScript archive `file`, on
/// the CPU. Throws std::runtime_error naming the file when it is missing or
/// not a TorchScript archive.
NamedTensors readTensorFile(const std::filesystem::path& file);

/// Atomically writes `tensors` as a TorchScript archive (a tree of empty
/// modules mirroring the dotted names, every tensor a buffer) that
/// readTensorFile() and Python's torch.jit.load read back.
void writeTensorFile(const std::filesystem::path& file,
                     const NamedTensors& tensors);

/// namedState(module) written with writeTensorFile().
void saveModule(const torch::nn::Module& module,
                const std::filesystem::path& file);

/// readTensorFile() then loadStateStrict() with the file as the source.
void loadModule(torch::nn::Module& module, const std::filesystem::path& file);

}  // namespace vln::models
