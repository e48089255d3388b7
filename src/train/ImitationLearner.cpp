#include "train/ImitationLearner.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <tuple>

#include "common/Check.h"
#include "common/Progress.h"
#include "models/Loss.h"
#include "train/Checkpoint.h"
#include "train/Distributed.h"

namespace vln::train {

double inverseInflectionFrequency(
    const std::vector<const data::GroundTruth*>& groundTruth) {
  int64_t actions = 0;
  int64_t inflections = 0;
  for (const data::GroundTruth* gt : groundTruth) {
    if (!gt) continue;
    for (const auto& [id, path] : *gt) {
      for (size_t t = 0; t < path.actions.size(); ++t) {
        ++actions;
        inflections += t == 0 || path.actions[t] != path.actions[t - 1];
      }
    }
  }
  VLN_CHECK_ARG(
      inflections > 0,
      "inverseInflectionFrequency(): the ground truth holds no actions, so "
      "trainer.inflection_weight <= 0 cannot be computed from it");
  return static_cast<double>(actions) / static_cast<double>(inflections);
}

ImitationLearner::ImitationLearner(std::shared_ptr<models::PolicyImpl> policy,
                                   const ExperimentConfig& config)
    : policy_(std::move(policy)),
      config_(config),
      device_(models::modelDevice(config.model)) {
  VLN_ASSERT(policy_ != nullptr);
  policy_->to(device_);
  for (const torch::Tensor& p : policy_->parameters())
    if (p.requires_grad()) parameters_.push_back(p);
  optimizer_ = std::make_unique<torch::optim::Adam>(
      parameters_, torch::optim::AdamOptions(config_.trainer.lr));
  inflectionCoef_ = config_.trainer.inflection_weight;
}

double ImitationLearner::applyGradients() {
  // multi-process training: the ranks' gradients are averaged here, before
  // clipping and the step, so every rank applies the same update
  if (dist_) dist_->averageGradients(parameters_);
  double norm = 0.0;
  if (config_.trainer.grad_clip > 0.0) {
    norm = torch::nn::utils::clip_grad_norm_(parameters_,
                                             config_.trainer.grad_clip);
  } else {
    double squares = 0.0;
    for (const torch::Tensor& p : parameters_)
      if (p.grad().defined()) squares += p.grad().pow(2).sum().item<double>();
    norm = std::sqrt(squares);
  }
  optimizer_->step();
  return norm;
}

ImitationLearner::BatchLosses ImitationLearner::batchLosses(
    const EpisodeBatch& batch) {
  policy_->train();
  const models::ModelConfig& model = config_.model;
  auto to = [&](const torch::Tensor& t) {
    return t.defined() ? t.to(device_) : t;
  };
  const torch::Tensor actions = to(batch.oracle_actions);
  const torch::Tensor valid = to(batch.valid);
  models::PolicyInputs inputs;
  inputs.rgb = to(batch.rgb);
  inputs.depth = to(batch.depth);
  inputs.prev_actions = to(batch.prev_actions);
  inputs.not_done = to(batch.not_done);
  const int64_t B = actions.size(1);

  // token ids, or the text features of an rxr_text model
  torch::Tensor instructionInput;
  if (model.usesInstruction() && model.usesTextFeatures()) {
    VLN_CHECK_ARG(batch.text_features.defined(),
                  "ImitationLearner::update(): model.instruction_features is "
                  "rxr_text but the batch carries no text features");
    instructionInput = to(batch.text_features);
  } else if (model.usesInstruction()) {
    instructionInput = to(batch.tokens);
  }

  const models::EncodedInstruction instruction =
      policy_->encodeInstruction(instructionInput);
  const models::PolicyOutputs out =
      policy_->forwardSequence(instruction, inputs, policy_->initialHidden(B));
  const torch::Tensor weights =
      models::inflectionWeights(actions, valid, inflectionCoef_);
  BatchLosses losses;
  losses.episodes = B;
  losses.action = models::weightedActionLoss(out.logits, actions, weights);
  if (model.progress_monitor)
    losses.progress =
        models::progressLoss(out.progress, to(batch.progress), valid);
  // the same steps replayed with episode b's instruction swapped for
  // episode b + 1's (cyclically): only words that make the oracle's
  // actions likelier for their own episode lower it
  if (config_.trainer.instruction_contrast_weight > 0.0 && B > 1) {
    const torch::Tensor swappedLogits =
        policy_
            ->forwardSequence(
                policy_->encodeInstruction(instructionInput.roll(-1, 0)),
                inputs, policy_->initialHidden(B))
            .logits;
    losses.contrast =
        models::instructionContrast(out.logits, swappedLogits, actions, valid);
  }
  return losses;
}

UpdateResult ImitationLearner::update(const EpisodeBatch& batch) {
  optimizer_->zero_grad();
  BatchLosses losses = batchLosses(batch);
  torch::Tensor& actionLoss = losses.action;
  torch::Tensor& progressLoss = losses.progress;
  torch::Tensor& contrast = losses.contrast;
  const int64_t B = losses.episodes;
  // multi-process: the update is that of the union of the ranks' batches.
  // The action loss is a mean over episodes and the progress loss one over
  // steps, so this rank's terms are weighted by its share of the episodes
  // and steps of all ranks; times the world size, which the gradient
  // averaging divides out again.
  if (dist_) {
    const std::vector<double> counts = dist_->allReduceSum(
        {static_cast<double>(B), static_cast<double>(batch.steps)});
    const auto world = static_cast<double>(dist_->worldSize());
    actionLoss = actionLoss * (world * static_cast<double>(B) / counts[0]);
    const double stepShare =
        world * static_cast<double>(batch.steps) / std::max(counts[1], 1.0);
    if (progressLoss.defined()) progressLoss = progressLoss * stepShare;
    if (contrast.defined()) contrast = contrast * stepShare;
  }
  torch::Tensor loss = actionLoss;
  if (progressLoss.defined())
    loss = loss + config_.trainer.progress_loss_weight * progressLoss;
  if (contrast.defined())
    loss = loss + config_.trainer.instruction_contrast_weight * contrast;
  if (lossHook_) loss = lossHook_(loss);

  UpdateResult result;
  result.steps = batch.steps;
  result.episodes = B;
  result.loss = loss.item<double>();
  result.action_loss = actionLoss.item<double>();
  result.progress_loss =
      progressLoss.defined() ? progressLoss.item<double>() : 0.0;
  result.instruction_contrast =
      contrast.defined() ? contrast.item<double>() : 0.0;
  const bool finiteHere = std::isfinite(result.loss);
  bool skip = !finiteHere;
  if (dist_) {
    // every rank skips when any rank's loss is non-finite (the all-reduces
    // must pair up); the reported losses are those of the union of the
    // batches: the means of the ranks' weighted terms
    const std::vector<double> sums = dist_->allReduceSum(
        {skip ? 1.0 : 0.0, skip ? 0.0 : result.loss,
         skip ? 0.0 : result.action_loss, skip ? 0.0 : result.progress_loss,
         static_cast<double>(result.steps),
         static_cast<double>(result.episodes),
         skip ? 0.0 : result.instruction_contrast});
    skip = sums[0] > 0.0;
    if (!skip) {
      const auto world = static_cast<double>(dist_->worldSize());
      result.loss = sums[1] / world;
      result.action_loss = sums[2] / world;
      result.progress_loss = sums[3] / world;
      result.instruction_contrast = sums[6] / world;
    }
    result.steps = static_cast<int64_t>(sums[4]);
    result.episodes = static_cast<int64_t>(sums[5]);
  }
  if (skip) return skipUpdate(result, finiteHere);
  loss.backward();
  result.grad_norm = applyGradients();
  nonFiniteInARow_ = 0;
  ++updates_;
  return result;
}

UpdateResult ImitationLearner::skipUpdate(UpdateResult result,
                                          bool finiteHere) {
  // skip: no gradient reaches the parameters or Adam's moments
  result.skipped = true;
  ++nonFiniteTotal_;
  ++nonFiniteInARow_;
  spdlog::warn(
      "non-finite loss ({}{}) at update {}: skipped ({} in a row, {} in "
      "total; limit trainer.max_nonfinite_updates = {})",
      result.loss, finiteHere ? " here, non-finite on another rank" : "",
      updates_, nonFiniteInARow_, nonFiniteTotal_,
      config_.trainer.max_nonfinite_updates);
  optimizer_->zero_grad();
  return result;
}

UpdateResult ImitationLearner::updateAccumulated(
    std::span<const EpisodeBatch> batches) {
  VLN_CHECK_ARG(!batches.empty(),
                "ImitationLearner::updateAccumulated(): no batches");
  VLN_CHECK_ARG(dist_ == nullptr,
                "ImitationLearner::updateAccumulated(): gradient "
                "accumulation does not run in a multi-process run");
  // the group's totals are known before any forward pass, so each batch's
  // terms can be weighted by its share right away and every graph freed
  // after its backward pass
  UpdateResult result;
  for (const EpisodeBatch& batch : batches) {
    result.episodes += batch.oracle_actions.size(1);
    result.steps += batch.steps;
  }
  const auto episodes = static_cast<double>(result.episodes);
  const double steps = std::max(static_cast<double>(result.steps), 1.0);

  optimizer_->zero_grad();
  for (const EpisodeBatch& batch : batches) {
    const BatchLosses losses = batchLosses(batch);
    // the action loss is a mean over episodes and the progress loss one
    // over steps: weighted by this batch's share of the group's episodes
    // and steps they sum to the losses of the concatenated batch
    const torch::Tensor actionLoss =
        losses.action * (static_cast<double>(losses.episodes) / episodes);
    torch::Tensor progressLoss;
    if (losses.progress.defined())
      progressLoss =
          losses.progress * (static_cast<double>(batch.steps) / steps);
    torch::Tensor contrast;
    if (losses.contrast.defined())
      contrast = losses.contrast * (static_cast<double>(batch.steps) / steps);
    torch::Tensor loss = actionLoss;
    if (progressLoss.defined())
      loss = loss + config_.trainer.progress_loss_weight * progressLoss;
    if (contrast.defined())
      loss = loss + config_.trainer.instruction_contrast_weight * contrast;
    if (lossHook_) loss = lossHook_(loss);
    const double value = loss.item<double>();
    result.loss += value;
    result.action_loss += actionLoss.item<double>();
    if (progressLoss.defined())
      result.progress_loss += progressLoss.item<double>();
    if (contrast.defined())
      result.instruction_contrast += contrast.item<double>();
    if (!std::isfinite(value)) return skipUpdate(result, /*finiteHere=*/false);
    loss.backward();
  }
  result.grad_norm = applyGradients();
  nonFiniteInARow_ = 0;
  ++updates_;
  return result;
}

EpochResult ImitationLearner::trainEpoch(
    const FeatureStore& store, uint64_t seed, int epoch,
    const std::function<void(const UpdateResult&)>& onUpdate) {
  VLN_CHECK_ARG(store.size() > 0, "ImitationLearner::trainEpoch(): the store '",
                store.dir().string(), "' holds no episodes");
  // The store holds episodes in the order their collection finished, which
  // depends on the slots a resumed round still had to collect; drawing the
  // batches over the (round, slot) order instead makes a run resumed after a
  // kill train on exactly the batches of an uninterrupted one.
  std::vector<int64_t> canonical(static_cast<size_t>(store.size()));
  std::iota(canonical.begin(), canonical.end(), int64_t{0});
  std::stable_sort(canonical.begin(), canonical.end(),
                   [&](int64_t a, int64_t b) {
                     const StoredEpisodeKey& ka = store.key(a);
                     const StoredEpisodeKey& kb = store.key(b);
                     return std::tie(ka.iteration, ka.slot) <
                            std::tie(kb.iteration, kb.slot);
                   });
  std::vector<int32_t> lengths;
  lengths.reserve(canonical.size());
  for (const int64_t i : canonical) lengths.push_back(store.key(i).length);
  auto batches = epochBatches(lengths, config_.trainer.batch_size, seed, epoch);
  for (auto& batch : batches)
    for (int64_t& i : batch) i = canonical[static_cast<size_t>(i)];
  if (dist_) {
    // as many updates on every rank: the largest count; the others go on
    // with their own batches from the start of this epoch's order
    const size_t own = batches.size();
    const auto count = static_cast<size_t>(
        dist_->allReduceMax({static_cast<int64_t>(own)}).front());
    for (size_t i = own; i < count; ++i) batches.push_back(batches[i % own]);
  }

  EpochResult result;
  result.lr = learningRate();
  common::Stopwatch clock;
  common::ProgressLine line(strCat("epoch ", epoch),
                            static_cast<int64_t>(batches.size()), "updates");
  for (const auto& indices : batches) {
    EpisodeBatch batch = store.loadBatch(indices);
    if (textFeatures_) batch.text_features = textFeatures_(store, indices);
    const UpdateResult u = update(batch);
    addToEpoch(u, epoch, result);
    if (onUpdate) onUpdate(u);
    line.advance();
  }
  finishEpoch(result);
  result.seconds = clock.seconds();
  return result;
}

double ImitationLearner::learningRate() const {
  return adamLearningRate(*optimizer_);
}

void ImitationLearner::addToEpoch(const UpdateResult& u, int epoch,
                                  EpochResult& result) const {
  if (u.skipped) {
    ++result.skipped;
    if (nonFiniteInARow_ >= config_.trainer.max_nonfinite_updates)
      throw std::runtime_error(strCat(
          "ImitationLearner: ", nonFiniteInARow_,
          " consecutive non-finite losses (trainer.max_nonfinite_updates = ",
          config_.trainer.max_nonfinite_updates, ") at update ", updates_,
          " of epoch ", epoch,
          ": training stopped, no checkpoint was written for this epoch"));
  } else {
    ++result.updates;
    result.mean.loss += u.loss;
    result.mean.action_loss += u.action_loss;
    result.mean.progress_loss += u.progress_loss;
    result.mean.instruction_contrast += u.instruction_contrast;
    result.mean.grad_norm += u.grad_norm;
  }
  result.mean.steps += u.steps;
  result.mean.episodes += u.episodes;
}

void ImitationLearner::finishEpoch(EpochResult& result) {
  if (result.updates == 0) return;
  const auto n = static_cast<double>(result.updates);
  result.mean.loss /= n;
  result.mean.action_loss /= n;
  result.mean.progress_loss /= n;
  result.mean.instruction_contrast /= n;
  result.mean.grad_norm /= n;
}

// ---------------------------------------------------------------------------
// logs

void logUpdate(const UpdateResult& u, int64_t update, int64_t epoch,
               int iteration, const ExperimentConfig& config,
               MetricsLog* metrics) {
  if (u.skipped) {
    if (metrics)
      metrics->write("nonfinite", {{"update", update}, {"loss", u.loss}}, {},
                     update);
    return;
  }
  if (update % config.trainer.log_every_updates != 0) return;
  spdlog::info(
      "update {}: loss {:.4f} (action {:.4f}, progress {:.4f}), grad norm "
      "{:.3f}",
      update, u.loss, u.action_loss, u.progress_loss, u.grad_norm);
  if (metrics)
    metrics->write("update",
                   {{"update", update},
                    {"epoch", epoch},
                    {"iteration", iteration},
                    {"loss", u.loss},
                    {"action_loss", u.action_loss},
                    {"progress_loss", u.progress_loss},
                    {"grad_norm", u.grad_norm},
                    {"steps", u.steps}},
                   {{"train/loss", u.loss},
                    {"train/action_loss", u.action_loss},
                    {"train/progress_loss", u.progress_loss},
                    {"train/grad_norm", u.grad_norm}},
                   update);
}

void logEpoch(const EpochResult& r, int64_t epoch, int iteration,
              int64_t storeEpisodes, double inflectionCoef,
              MetricsLog* metrics) {
  const double rate =
      r.seconds > 0 ? static_cast<double>(r.updates) / r.seconds : 0.0;
  spdlog::info(
      "epoch {} (iteration {}): {} updates ({} skipped) in {:.1f} s ({:.2f} "
      "updates/s), mean loss {:.4f} (action {:.4f}, progress {:.4f}), {} "
      "episodes in the store",
      epoch, iteration, r.updates, r.skipped, r.seconds, rate, r.mean.loss,
      r.mean.action_loss, r.mean.progress_loss, storeEpisodes);
  if (metrics)
    metrics->write("epoch",
                   {{"epoch", epoch},
                    {"iteration", iteration},
                    {"updates", r.updates},
                    {"skipped", r.skipped},
                    {"seconds", r.seconds},
                    {"updates_per_second", rate},
                    {"lr", r.lr},
                    {"loss", r.mean.loss},
                    {"action_loss", r.mean.action_loss},
                    {"progress_loss", r.mean.progress_loss},
                    {"instruction_contrast", r.mean.instruction_contrast},
                    {"store_episodes", storeEpisodes},
                    {"inflection_coef", inflectionCoef}},
                   {{"epoch/loss", r.mean.loss},
                    {"epoch/action_loss", r.mean.action_loss},
                    {"epoch/progress_loss", r.mean.progress_loss},
                    {"epoch/updates_per_second", rate}},
                   epoch);
}

}  // namespace vln::train
