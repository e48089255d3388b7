#pragma once
// The gradient side of imitation learning (paper Section 4.3): batches of
// whole episodes from the feature store, the policy in sequence mode, the
// inflection-weighted action loss plus the progress-monitor loss, Adam.
//
// Numeric faults follow the project's policy: a NaN or infinite loss skips
// its update (no gradient is applied), is counted and logged; after
// trainer.max_nonfinite_updates of them in a row, train() throws.
//
// Every optimizer step goes through applyGradients(): that is the one place
// where a multi-process run inserts its gradient all-reduce
// (setDistributed()).

#include <torch/torch.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <span>

#include "data/GroundTruth.h"
#include "models/Policy.h"
#include "train/ExperimentConfig.h"
#include "train/FeatureStore.h"
#include "train/MetricsLog.h"

namespace vln::train {

class Distributed;

/// The losses of one update (or their means over an epoch).
struct UpdateResult {
  double loss = 0.0;  ///< action_loss + alpha * progress_loss + contrast term
  double action_loss = 0.0;    ///< inflection-weighted cross-entropy
  double progress_loss = 0.0;  ///< progress MSE (0 without progress monitor)
  /// models::instructionContrast() of the batch's oracle actions with each
  /// episode's instruction swapped for the next episode's (0 when
  /// trainer.instruction_contrast_weight is 0)
  double instruction_contrast = 0.0;
  double grad_norm = 0.0;      ///< total gradient norm before clipping
  int64_t steps = 0;           ///< real steps in the batch
  int64_t episodes = 0;        ///< episodes in the batch
  bool skipped = false;        ///< non-finite loss: no update was applied
};

/// Sums of an epoch.
struct EpochResult {
  UpdateResult mean;    ///< means over the applied updates
  int64_t updates = 0;  ///< applied updates
  int64_t skipped = 0;  ///< updates skipped for non-finite losses
  double seconds = 0.0;
  double lr = 0.0;  ///< the learning rate the epoch trained at
};

/// VLN-CE's inflection coefficient: the inverse frequency of inflections
/// (t = 0 and every action that differs from the previous one) over the
/// ground-truth action sequences, i.e. total actions / inflections. Throws
/// std::invalid_argument when `groundTruth` holds no actions.
double inverseInflectionFrequency(
    const std::vector<const data::GroundTruth*>& groundTruth);

class ImitationLearner {
 public:
  /// Trains `policy` (moved to model.device) with Adam(trainer.lr) over
  /// its trainable parameters.
  ImitationLearner(std::shared_ptr<models::PolicyImpl> policy,
                   const ExperimentConfig& config);

  /// Trains as one rank of a multi-process run (Distributed.h; nullptr:
  /// this process alone, the default). Then every update is that of the
  /// union of the ranks' batches: each rank weights its action loss (a mean
  /// over episodes) by its share of all ranks' episodes and its progress
  /// loss (a mean over steps) by its share of their steps, the gradients
  /// are combined over the ranks before clipping and the step, a non-finite
  /// loss on any rank skips the update on every rank, and UpdateResult
  /// holds the union's losses, steps and episodes (grad_norm is that of the
  /// combined gradient). Every epoch has as many updates on every rank
  /// (trainEpoch()). Two all-reduces of counters and one of the gradients
  /// per update. `dist` must outlive the learner.
  void setDistributed(Distributed* dist) { dist_ = dist; }

  /// Fills EpisodeBatch::text_features of each batch trainEpoch() loads
  /// (the store keeps no text): `fill(store, indices)` returns
  /// [B, L, model.text_feature_dim] for the stored episodes `indices`
  /// (TrainingData::batchTextFeatures()). Needed by a model with
  /// model.instruction_features: rxr_text.
  using TextFeatureFill =
      std::function<at::Tensor(const FeatureStore&, std::span<const int64_t>)>;
  void setTextFeatures(TextFeatureFill fill) {
    textFeatures_ = std::move(fill);
  }

  /// Inflection coefficient of the action loss.
  void setInflectionCoef(double coef) { inflectionCoef_ = coef; }
  double inflectionCoef() const { return inflectionCoef_; }

  /// One update on `batch` (CPU tensors from FeatureStore::loadBatch).
  UpdateResult update(const EpisodeBatch& batch);

  /// One update on `batches` together (gradient accumulation: one forward
  /// and backward pass per batch, then one optimizer step): the gradient,
  /// the step and the losses are those of update() on the batches
  /// concatenated into one, to float rounding. Each batch's action loss (a
  /// mean over its episodes) is weighted by its share of all the episodes
  /// and its progress loss (a mean over its steps) by its share of all the
  /// steps, so batches of unequal sizes are exact too. (VLN-CE's recollect
  /// trainer divides every batch's loss by the number of batches, which is
  /// the same for the action loss of equal batches only.) A non-finite
  /// loss in any batch skips the whole update. Not in a multi-process run
  /// (std::invalid_argument).
  UpdateResult updateAccumulated(std::span<const EpisodeBatch> batches);

  /// One epoch over `store` in epochBatches(seed, epoch) order, taken over
  /// the episodes sorted by (round, slot), not by their place in the store:
  /// the batches do not depend on the order in which collection finished.
  /// Multi-process: every rank runs U = the largest batch count over the
  /// ranks; a rank with fewer batches continues with its own batches from
  /// the start of the same order (batch i % count), so the all-reduces pair
  /// up and every stored episode is seen at least once per epoch.
  /// `onUpdate` sees every update (applied or skipped). Throws
  /// std::runtime_error after trainer.max_nonfinite_updates consecutive
  /// non-finite losses.
  EpochResult trainEpoch(
      const FeatureStore& store, uint64_t seed, int epoch,
      const std::function<void(const UpdateResult&)>& onUpdate = {});

  /// Adds update `u` of epoch `epoch` to `result`'s counts and sums (the
  /// bookkeeping of trainEpoch(), for trainers that draw their own
  /// batches). Throws std::runtime_error after
  /// trainer.max_nonfinite_updates consecutive non-finite losses.
  void addToEpoch(const UpdateResult& u, int epoch, EpochResult& result) const;
  /// Turns `result`'s sums over its applied updates into means.
  static void finishEpoch(EpochResult& result);

  torch::optim::Adam& optimizer() { return *optimizer_; }
  /// The learning rate of the optimizer's (first) parameter group.
  double learningRate() const;
  models::PolicyImpl& policy() { return *policy_; }
  /// Applied updates so far (restored from checkpoints with setUpdates()).
  int64_t updates() const { return updates_; }
  void setUpdates(int64_t updates) { updates_ = updates; }
  /// Non-finite losses so far (total and current run of consecutive ones).
  int64_t nonFiniteTotal() const { return nonFiniteTotal_; }
  int64_t nonFiniteInARow() const { return nonFiniteInARow_; }

  /// Test hook: transforms the loss before the finiteness check (e.g. to
  /// inject a NaN).
  void setLossHook(std::function<torch::Tensor(const torch::Tensor&)> hook) {
    lossHook_ = std::move(hook);
  }

 private:
  /// The gradient all-reduce (multi-process), clipping and the optimizer
  /// step. Returns the gradient norm before clipping.
  double applyGradients();

  /// The losses of one batch, forward pass done, graph kept.
  struct BatchLosses {
    torch::Tensor action;    ///< mean over the batch's episodes
    torch::Tensor progress;  ///< mean over its steps; undefined without PM
    torch::Tensor contrast;  ///< mean over its steps; undefined when off
    int64_t episodes = 0;
  };
  BatchLosses batchLosses(const EpisodeBatch& batch);
  /// Counts and logs a non-finite update (`finiteHere`: only another
  /// rank's loss was non-finite) and drops its gradients.
  UpdateResult skipUpdate(UpdateResult result, bool finiteHere);

  std::shared_ptr<models::PolicyImpl> policy_;
  ExperimentConfig config_;
  torch::Device device_;
  std::unique_ptr<torch::optim::Adam> optimizer_;
  std::vector<torch::Tensor> parameters_;
  double inflectionCoef_ = 3.2;
  int64_t updates_ = 0;
  int64_t nonFiniteTotal_ = 0;
  int64_t nonFiniteInARow_ = 0;
  std::function<torch::Tensor(const torch::Tensor&)> lossHook_;
  TextFeatureFill textFeatures_;
  Distributed* dist_ = nullptr;
};

/// Logs update `update` of epoch `epoch` (epochs done before it) of
/// iteration `iteration`: a skipped update as a "nonfinite" record, every
/// trainer.log_every_updates-th as a log line and an "update" record.
/// `metrics` may be null (log lines only).
void logUpdate(const UpdateResult& result, int64_t update, int64_t epoch,
               int iteration, const ExperimentConfig& config,
               MetricsLog* metrics);

/// Logs a finished epoch (`epoch` counts the epochs done, this one
/// included) as a log line and an "epoch" record; `metrics` may be null.
void logEpoch(const EpochResult& result, int64_t epoch, int iteration,
              int64_t storeEpisodes, double inflectionCoef,
              MetricsLog* metrics);

}  // namespace vln::train
