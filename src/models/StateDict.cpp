#include "models/StateDict.h"

#include <torch/script.h>

#include <map>
#include <sstream>

#include "common/Check.h"
#include "common/FileIo.h"
#include "common/ZipIntegrity.h"

namespace vln::models {
namespace {

std::string shapeString(const torch::Tensor& t) {
  std::ostringstream out;
  out << t.sizes();
  return out.str();
}

// walks (creating on demand) the chain of submodules named by the dotted
// prefix of `name` and returns the module that owns the leaf
torch::jit::Module ownerOf(torch::jit::Module root, const std::string& name,
                           std::string* leaf, int* classCounter) {
  torch::jit::Module current = std::move(root);
  size_t begin = 0;
  for (size_t dot = name.find('.'); dot != std::string::npos;
       dot = name.find('.', begin)) {
    const std::string part = name.substr(begin, dot - begin);
    if (!current.hasattr(part)) {
      // each node gets its own class: the archive must not hold two
      // different types under one qualified name
      torch::jit::Module child(c10::QualifiedName(
          "__torch__.vln.TensorNode" + std::to_string((*classCounter)++)));
      current.register_module(part, child);
    }
    const c10::IValue node = current.attr(part);
    VLN_CHECK_ARG(node.isModule(), "writeTensorFile(): tensor name '", name,
                  "' nests under '", part, "', which is itself a tensor");
    current = node.toModule();
    begin = dot + 1;
  }
  *leaf = name.substr(begin);
  return current;
}

}  // namespace

NamedTensors namedState(const torch::nn::Module& module) {
  NamedTensors out;
  for (const auto& item : module.named_parameters(/*recurse=*/true))
    out.emplace_back(item.key(), item.value());
  for (const auto& item : module.named_buffers(/*recurse=*/true))
    out.emplace_back(item.key(), item.value());
  return out;
}

void loadStateStrict(torch::nn::Module& module, const NamedTensors& tensors,
                     std::string_view source) {
  const NamedTensors targets = namedState(module);
  std::map<std::string, torch::Tensor> given;
  std::vector<std::string> duplicates;
  for (const auto& [name, tensor] : tensors)
    if (!given.emplace(name, tensor).second) duplicates.push_back(name);

  // compare both name sets and every shape before touching the module, so a
  // failed load leaves it unchanged
  std::vector<std::string> missing, unexpected, mismatched;
  std::map<std::string, const torch::Tensor*> expected;
  for (const auto& [name, target] : targets) {
    expected.emplace(name, &target);
    auto it = given.find(name);
    if (it == given.end()) {
      missing.push_back(name + " " + shapeString(target));
    } else if (!it->second.defined() || it->second.sizes() != target.sizes()) {
      mismatched.push_back(name + " expected " + shapeString(target) +
                           ", got " +
                           (it->second.defined() ? shapeString(it->second)
                                                 : std::string("undefined")));
    }
  }
  for (const auto& [name, tensor] : given)
    if (!expected.count(name))
      unexpected.push_back(name + " " + shapeString(tensor));

  if (!missing.empty() || !unexpected.empty() || !mismatched.empty() ||
      !duplicates.empty()) {
    std::ostringstream msg;
    msg << "loadStateStrict(): " << source
        << " does not match the module's tensors:";
    auto list = [&](const char* what, const std::vector<std::string>& items) {
      if (items.empty()) return;
      msg << "\n  " << what << " (" << items.size() << "):";
      for (const auto& item : items) msg << "\n    " << item;
    };
    list("missing", missing);
    list("unexpected", unexpected);
    list("shape mismatch", mismatched);
    list("duplicate", duplicates);
    throw std::invalid_argument(msg.str());
  }

  torch::NoGradGuard noGrad;
  for (const auto& [name, target] : targets) {
    torch::Tensor dst = target;  // shares storage with the module
    dst.copy_(given.at(name));
  }
}

NamedTensors stripPrefix(const NamedTensors& tensors, std::string_view prefix) {
  NamedTensors out;
  for (const auto& [name, tensor] : tensors)
    if (name.size() > prefix.size() &&
        name.compare(0, prefix.size(), prefix) == 0)
      out.emplace_back(name.substr(prefix.size()), tensor);
  return out;
}

NamedTensors readTensorFile(const std::filesystem::path& file) {
  VLN_CHECK_IO(std::filesystem::is_regular_file(file),
               "readTensorFile(): weight file '", file.string(),
               "' does not exist");
  // checked first: LibTorch reads damaged archives without checking their
  // CRCs, and its TorchScript parser can crash on them
  const std::string bytes = common::readFile(file);
  try {
    common::verifyZipIntegrity(bytes, file.string());
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(strCat("readTensorFile(): ", e.what()));
  }
  torch::jit::Module archive;
  try {
    std::istringstream in(bytes);
    archive = torch::jit::load(in, torch::kCPU);
  } catch (const c10::Error& e) {
    throw std::runtime_error(strCat("readTensorFile(): '", file.string(),
                                    "' is not a readable TorchScript archive: ",
                                    e.what_without_backtrace()));
  } catch (const std::exception& e) {
    throw std::runtime_error(
        strCat("readTensorFile(): '", file.string(),
               "' is not a readable TorchScript archive: ", e.what()));
  }
  NamedTensors out;
  for (const auto& item : archive.named_parameters(/*recurse=*/true))
    out.emplace_back(item.name, item.value);
  for (const auto& item : archive.named_buffers(/*recurse=*/true))
    out.emplace_back(item.name, item.value);
  return out;
}

void writeTensorFile(const std::filesystem::path& file,
                     const NamedTensors& tensors) {
  torch::jit::Module root(c10::QualifiedName("__torch__.vln.TensorFile"));
  int classCounter = 0;
  for (const auto& [name, tensor] : tensors) {
    VLN_CHECK_ARG(!name.empty() && name.front() != '.' && name.back() != '.' &&
                      name.find("..") == std::string::npos,
                  "writeTensorFile(): bad tensor name '", name, "' for '",
                  file.string(), "'");
    std::string leaf;
    torch::jit::Module owner = ownerOf(root, name, &leaf, &classCounter);
    VLN_CHECK_ARG(!owner.hasattr(leaf), "writeTensorFile(): tensor name '",
                  name, "' is used twice for '", file.string(), "'");
    owner.register_buffer(leaf, tensor.detach().to(torch::kCPU).contiguous());
  }
  std::ostringstream bytes;
  root.save(bytes);
  common::writeFileAtomic(file, bytes.str());
}

void saveModule(const torch::nn::Module& module,
                const std::filesystem::path& file) {
  writeTensorFile(file, namedState(module));
}

void loadModule(torch::nn::Module& module, const std::filesystem::path& file) {
  loadStateStrict(module, readTensorFile(file), file.string());
}

}  // namespace vln::models
