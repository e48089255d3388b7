#pragma once
// The imitation-learning losses of the paper (Section 4.3): teacher forcing
// with inflection weighting (Wijmans et al. 2019, as in VLN-CE's trainer)
// and the progress monitor's regression (Ma et al. 2019). Time-major
// [T, B] layouts, as produced by PolicyImpl::forwardSequence(); episodes
// shorter than T are padded and `valid` marks their real steps.

#include <ATen/core/Tensor.h>

namespace vln::models {

/// Loss weights [T, B] float: `coef` at inflections (t = 0 and every step
/// whose action differs from the previous step's), 1 elsewhere, 0 where
/// valid is false. actions int64 [T, B], valid bool [T, B]. VLN-CE's
/// coefficient for R2R is 3.2 (inverse inflection frequency).
at::Tensor inflectionWeights(const at::Tensor& actions,
                                const at::Tensor& valid, double coef);

/// Inflection-weighted cross-entropy: for each episode
/// sum_t w * CE(logits_t, action_t) / sum_t w, then the mean over episodes.
/// logits [T, B, A] float, actions int64 [T, B] (any value where w = 0),
/// weights [T, B] float. Returns a scalar.
at::Tensor weightedActionLoss(const at::Tensor& logits,
                                 const at::Tensor& actions,
                                 const at::Tensor& weights);

/// Mean squared error between predicted and true progress over the valid
/// steps of the whole batch (VLN-CE's AuxLosses reduction). progress and
/// target [T, B] float, valid bool [T, B]. Returns a scalar.
at::Tensor progressLoss(const at::Tensor& progress,
                           const at::Tensor& target,
                           const at::Tensor& valid);

/// The instruction contrast of decisions labelled `labels` (int64, any
/// value where `valid` is false): for each valid decision
/// softplus(log p_swapped(label) - log p_own(label)), with `ownLogits` the
/// policy's logits under the episode's own instruction and `swappedLogits`
/// under another episode's, averaged over the valid decisions. ln 2 when
/// the words change nothing; below it only when the episode's own words
/// make the label likelier than another's do. Logits [..., A] float,
/// labels and valid (bool) of their leading shape. Returns a scalar.
at::Tensor instructionContrast(const at::Tensor& ownLogits,
                               const at::Tensor& swappedLogits,
                               const at::Tensor& labels,
                               const at::Tensor& valid);

}  // namespace vln::models
