#include "rollout/ExportedArchive.h"

#include <algorithm>
#include <sstream>

#include "common/Check.h"
#include "common/Config.h"
#include "common/FileIo.h"
#include "common/ZipIntegrity.h"
#include "data/Vocabulary.h"

namespace vln::rollout {

torch::Device parseDevice(const std::string& device, std::string_view who) {
  try {
    return torch::Device(device);
  } catch (const c10::Error&) {
    throw std::invalid_argument(
        strCat(who, ": device '", device, "' cannot be parsed"));
  }
}

torch::jit::Module loadExportedArchive(const std::filesystem::path& file,
                                       const std::string& device,
                                       std::string_view who) {
  VLN_CHECK_IO(std::filesystem::is_regular_file(file), who, ": '",
               file.string(), "' does not exist");
  const torch::Device parsed = parseDevice(device, who);
  const std::string bytes = common::readFile(file);
  try {
    common::verifyZipIntegrity(bytes, file.string());
  } catch (const std::runtime_error& error) {
    throw std::runtime_error(strCat(who, ": ", error.what()));
  }
  torch::jit::Module module;
  try {
    std::istringstream in(bytes);
    module = torch::jit::load(in, parsed);
  } catch (const c10::Error& error) {
    throw std::runtime_error(strCat(who, ": '", file.string(),
                                    "' is not a TorchScript archive: ",
                                    error.what_without_backtrace()));
  } catch (const std::exception& error) {
    throw std::runtime_error(strCat(who, ": '", file.string(),
                                    "' is not a TorchScript archive: ",
                                    error.what()));
  }
  module.eval();
  return module;
}

models::ModelConfig exportedModelConfig(const torch::jit::Module& module,
                                        const std::filesystem::path& file) {
  VLN_CHECK_ARG(module.hasattr("model_config"), "'", file.string(),
                "' has no 'model_config' attribute (not written by "
                "vlnce-export or train --export?)");
  const c10::IValue value = module.attr("model_config");
  VLN_CHECK_ARG(value.isString(), "'", file.string(),
                "': attribute 'model_config' is not a string");
  return common::loadConfigText<models::ModelConfig>(
      value.toStringRef(), file.string() + " model_config");
}

bool isWaypointExport(const torch::jit::Module& module) {
  return module.hasattr("num_views");
}

void checkRunsOnObservations(const torch::jit::Module& module,
                             const models::ModelConfig& config,
                             const std::filesystem::path& file,
                             std::string_view who) {
  // the agents feed token ids; text features would need a feature source
  // (PolicyStepper::setInstructionFeatures)
  VLN_CHECK_ARG(!config.usesInstruction() || !config.usesTextFeatures(), who,
                ": '", file.string(),
                "' reads text features (model.instruction_features: "
                "rxr_text); scripted agents feed instruction tokens only");
  auto hasMethod = [&](const char* name) {
    return module.find_method(name).has_value();
  };
  VLN_CHECK_ARG(!config.usesRgb() || hasMethod("encode_rgb"), who, ": '",
                file.string(),
                "' was exported without its RGB encoder (forward takes "
                "features); export it with the encoders");
  VLN_CHECK_ARG(!config.usesDepth() || hasMethod("encode_depth"), who, ": '",
                file.string(),
                "' was exported without its depth encoder (forward takes "
                "features); export it with the encoders");
}

std::vector<int64_t> archiveTokens(const data::Episode& episode,
                                   const models::ModelConfig& config,
                                   int maxLength, std::string_view who) {
  std::vector<int64_t> tokens;
  if (!config.usesInstruction()) return tokens;
  const auto& source = episode.instruction.instruction_tokens;
  const int length = std::min(maxLength, data::unpaddedLength(source));
  VLN_CHECK_ARG(length >= 1, who, "::reset(): episode ", episode.episode_id,
                " has no instruction tokens");
  for (int j = 0; j < length; ++j)
    tokens.push_back(source[static_cast<size_t>(j)]);
  return tokens;
}

at::Tensor tokenBatch(std::span<const std::vector<int64_t>* const> rows,
                      const models::ModelConfig& config) {
  size_t longest = 1;
  for (const auto* row : rows) longest = std::max(longest, row->size());
  torch::Tensor tokens =
      torch::zeros({static_cast<int64_t>(rows.size()),
                    static_cast<int64_t>(longest)},
                   torch::kInt64);
  if (!config.usesInstruction()) tokens.fill_(1);
  auto out = tokens.accessor<int64_t, 2>();
  for (size_t k = 0; k < rows.size(); ++k)
    for (size_t j = 0; j < rows[k]->size(); ++j)
      out[static_cast<int64_t>(k)][static_cast<int64_t>(j)] = (*rows[k])[j];
  return tokens;
}

}  // namespace vln::rollout
