#pragma once
// An exported TorchScript policy (models::exportPolicy(), with its
// observation encoders) as an evaluation Agent: the archive's `forward`
// takes raw observations, the instruction tokens, the previous action,
// not_done and the recurrent state, one step per act(), exactly the protocol
// of PolicyAgent (per-environment state, argmax or per-episode seeded
// sampling through chooseAction()). The model config stored in the archive
// (`model_config`) gives the image sizes, modalities and state shape; no
// project code beyond the archive is needed to run it.

#include <torch/script.h>

#include <filesystem>
#include <memory>
#include <random>
#include <span>
#include <vector>

#include "models/ModelConfig.h"
#include "rollout/Agent.h"
#include "rollout/ExportedArchive.h"

namespace vln::rollout {

class ScriptedPolicyAgent : public Agent {
 public:
  /// Loads `file` onto `device` ("cpu", "cuda", ...). Throws
  /// std::runtime_error naming the file when it is missing or not a
  /// TorchScript archive, and std::invalid_argument when it has no
  /// `model_config` attribute, is a waypoint policy's export
  /// (models::exportWaypointPolicy()) or was exported without the encoders
  /// of the modalities it uses (its forward then takes features, not
  /// images).
  ScriptedPolicyAgent(const std::filesystem::path& file, int numEnvs,
                      bool sampleActions, uint64_t seed,
                      int maxInstructionLength,
                      const std::string& device = "cpu");
  /// The same over an archive already loaded (loadExportedArchive()) onto
  /// `device`; `file` names it in errors.
  ScriptedPolicyAgent(torch::jit::Module module,
                      const std::filesystem::path& file, int numEnvs,
                      bool sampleActions, uint64_t seed,
                      int maxInstructionLength, torch::Device device);
  ~ScriptedPolicyAgent() override;

  void reset(int env, const data::Episode& episode) override;
  std::vector<sim::Action> act(VectorEnv& envs,
                               std::span<const int> active) override;

  /// The model config stored in the archive.
  const models::ModelConfig& config() const { return config_; }

 private:
  struct EnvState;

  std::filesystem::path file_;
  torch::jit::Module module_;
  models::ModelConfig config_;
  torch::Device device_;
  bool sample_;
  uint64_t seed_;
  int maxInstructionLength_;
  std::vector<EnvState> states_;
};

}  // namespace vln::rollout
