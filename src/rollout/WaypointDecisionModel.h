#pragma once
// What a WaypointAgent (rollout/WaypointAgent.h) decides with: the networks
// that turn a panorama and an instruction into candidate waypoints and a
// choice among them. Two kinds: the project's modules as trained
// (NativeWaypointModel: the waypoint CMA, the frozen encoders, the learned
// predictor) and an exported TorchScript archive (ScriptedWaypointModel,
// rollout/ScriptedWaypointModel.h), so that `eval` scores an export with the
// same execution, step limit, oracle-free choice rule and metrics as the
// checkpoint it came from. The agent keeps what does not depend on the
// networks: executing waypoints, the oracle, the depth-only baseline's
// candidates, the per-episode draws and the recorded decisions.

#include <ATen/core/Tensor.h>

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "data/Episode.h"
#include "models/ModelConfig.h"
#include "models/ObservationEncoder.h"
#include "models/WaypointCmaPolicy.h"
#include "models/WaypointPredictor.h"
#include "waypoint/WaypointHeatmap.h"

namespace vln::rollout {

/// Each panorama view's encoder features, [n, N, F] float (undefined for a
/// modality the policy does not use).
struct PanoramaFeatures {
  at::Tensor rgb;
  at::Tensor depth;
};

/// How the learned predictor's heatmap becomes candidates
/// (waypoint::heatmapNms()).
struct CandidateNms {
  int max_candidates = 5;
  int heading_radius = 7;
  int distance_radius = 5;
  float min_score = 0.0f;
};

class WaypointDecisionModel {
 public:
  virtual ~WaypointDecisionModel() = default;

  /// The policy's model config (modalities, image sizes, hidden size).
  virtual const models::ModelConfig& config() const = 0;
  /// Panorama views the policy reads.
  virtual int numViews() const = 0;
  /// Starts `env`'s episode: its instruction, a zero recurrent state.
  virtual void reset(int env, const data::Episode& episode) = 0;
  /// The views' features of `n` panoramas: rgb uint8 [n, N, h, w, 3] and
  /// depth float [n, N, h, w, 1] on the CPU (undefined where unused).
  virtual PanoramaFeatures encode(const at::Tensor& rgb,
                                  const at::Tensor& depth) = 0;
  /// Whether propose() can give candidates (a learned predictor is there).
  virtual bool proposes() const = 0;
  /// The learned predictor's candidates of each panorama, best first
  /// (waypoint::heatmapNms() of its heatmap).
  virtual std::vector<std::vector<waypoint::Candidate>> propose(
      const PanoramaFeatures& features) = 0;
  /// One decision of environments `envs` (row i is envs[i]), all inputs on
  /// the CPU: `candidates` float [n, K, 2] (heading, distance), `mask` bool
  /// [n, K], `prev` float [n, 2], `notDone` float [n]; `textMask` bool
  /// [n, L'] the words each decision may read (models::WaypointPolicyInputs::
  /// text_mask), undefined for all of them. Returns the logits float64
  /// [n, 1 + K] on the CPU (0 STOP, j + 1 candidate j; -inf at masked
  /// slots) and advances each environment's recurrent state.
  /// With model.clause_tracker, the clause environment `env`'s last step()
  /// read from (the first policy's pointer); -1 otherwise.
  virtual int clauseRead(int /*env*/) const { return -1; }
  virtual at::Tensor step(std::span<const int> envs,
                          const PanoramaFeatures& features,
                          const at::Tensor& candidates, const at::Tensor& mask,
                          const at::Tensor& prev, const at::Tensor& notDone,
                          const at::Tensor& textMask) = 0;
};

/// The probabilities of an ensemble's members averaged: `memberLogits`
/// (each float64 [n, 1 + K], -inf at masked slots, at least one) become
/// log(mean_m softmax(logits_m)) per row, -inf where every member masks.
/// Averaging probabilities rather than logits keeps one member's confident
/// choice from being outvoted by logits of another scale.
at::Tensor ensembleLogits(std::span<const at::Tensor> memberLogits);

/// The project's modules: the policy, its frozen encoders and (unless
/// null) the learned predictor with `nms`. They run in eval mode under
/// NoGradGuard on the policy's device; the policy is shared with the
/// trainer, which updates it between rounds.
///
/// With more than one policy the model is an ensemble (eval --ensemble):
/// every member reads the same encoder features and candidates, keeps its
/// own recurrent state and instruction encoding, and step() returns
/// ensembleLogits() of their logits. The members must read the same
/// modalities and views (std::invalid_argument otherwise): they are
/// policies of one recipe trained under different seeds, over the same
/// frozen encoders and predictor.
class NativeWaypointModel : public WaypointDecisionModel {
 public:
  NativeWaypointModel(std::shared_ptr<models::WaypointCmaPolicyImpl> policy,
                      models::ObservationEncoder encoder,
                      models::WaypointPredictor predictor, CandidateNms nms,
                      int maxInstructionLength);
  NativeWaypointModel(
      std::vector<std::shared_ptr<models::WaypointCmaPolicyImpl>> policies,
      models::ObservationEncoder encoder, models::WaypointPredictor predictor,
      CandidateNms nms, int maxInstructionLength);
  ~NativeWaypointModel() override;

  const models::ModelConfig& config() const override;
  int numViews() const override;
  void reset(int env, const data::Episode& episode) override;
  PanoramaFeatures encode(const at::Tensor& rgb,
                          const at::Tensor& depth) override;
  bool proposes() const override { return !predictor_.is_empty(); }
  std::vector<std::vector<waypoint::Candidate>> propose(
      const PanoramaFeatures& features) override;
  at::Tensor step(std::span<const int> envs, const PanoramaFeatures& features,
                  const at::Tensor& candidates, const at::Tensor& mask,
                  const at::Tensor& prev, const at::Tensor& notDone,
                  const at::Tensor& textMask) override;
  int clauseRead(int env) const override;

 private:
  struct EnvState;
  EnvState& state(int env);

  // policies_[0] is the policy; more are ensemble members
  std::vector<std::shared_ptr<models::WaypointCmaPolicyImpl>> policies_;
  models::ObservationEncoder encoder_;
  models::WaypointPredictor predictor_;
  CandidateNms nms_;
  int maxInstructionLength_;
  std::vector<std::unique_ptr<EnvState>> states_;
};

}  // namespace vln::rollout
