#pragma once
// An exported waypoint agent (models::exportWaypointPolicy(), written by
// vlnce-export or train --export) as the networks of a WaypointAgent
// (WaypointDecisionModel.h): the archive's encode_rgb / encode_depth give
// the views' features, its propose_features the candidates (when it
// includes the predictor), and step_features the choice, with the
// instruction tokens (with model.goal_match also the goal labels, built as
// for the checkpoint: batchGoalLabels()) and recurrent state kept per
// environment here. The
// agent around it executes the waypoints as for a checkpoint (walk or
// teleport, waypoint_agent.*), so `eval --checkpoint agent.pt` scores an
// export like the checkpoint it came from. The model config, the views and
// the suppression come from the archive; no project module is built.

#include <torch/script.h>

#include <filesystem>
#include <string>
#include <vector>

#include "rollout/WaypointDecisionModel.h"

namespace vln::rollout {

class ScriptedWaypointModel : public WaypointDecisionModel {
 public:
  /// Loads `file` onto `device` (loadExportedArchive()). Throws what that
  /// throws, and std::invalid_argument naming the file when it is not a
  /// waypoint export, reads text features, lacks the encoders of the
  /// modalities it uses, or matches goal labels (model.goal_match) other
  /// than world::goalLabels()' (model.rgb_semantic_outputs is not
  /// world::viewLabelSize()).
  ScriptedWaypointModel(const std::filesystem::path& file,
                        int maxInstructionLength,
                        const std::string& device = "cpu");
  /// The same over an archive already loaded onto `device`.
  ScriptedWaypointModel(torch::jit::Module module,
                        const std::filesystem::path& file,
                        int maxInstructionLength, torch::Device device);
  ~ScriptedWaypointModel() override;

  const models::ModelConfig& config() const override { return config_; }
  int numViews() const override { return numViews_; }
  void reset(int env, const data::Episode& episode) override;
  PanoramaFeatures encode(const at::Tensor& rgb,
                          const at::Tensor& depth) override;
  /// Whether the archive includes the predictor (has_predictor).
  bool proposes() const override { return hasPredictor_; }
  std::vector<std::vector<waypoint::Candidate>> propose(
      const PanoramaFeatures& features) override;
  at::Tensor step(std::span<const int> envs, const PanoramaFeatures& features,
                  const at::Tensor& candidates, const at::Tensor& mask,
                  const at::Tensor& prev, const at::Tensor& notDone,
                  const at::Tensor& textMask) override;

 private:
  struct EnvState {
    bool started = false;
    std::vector<int64_t> tokens;
    at::Tensor goalLabels;  // [F_rgb] with model.goal_match
    at::Tensor hidden;      // [2, H]
  };
  EnvState& state(int env);
  // the tensor a method receives for an unused modality (ignored there)
  at::Tensor orPlaceholder(const at::Tensor& features, int64_t n) const;

  std::filesystem::path file_;
  torch::jit::Module module_;
  torch::Device device_;
  models::ModelConfig config_;
  int numViews_ = 0;
  bool hasPredictor_ = false;
  int maxInstructionLength_;
  std::vector<EnvState> states_;
};

}  // namespace vln::rollout
