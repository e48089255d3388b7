#pragma once
// Training the CMA agent over candidate waypoints (trainer.task =
// waypoint_cma; issue 18, docs/waypoints.md) by DAgger, as Hong et al.
// (CVPR 2022) train theirs, on the trainer's usual schedule
// (train/TrainingSchedule.h: trainer.dagger_iterations, dagger_episodes,
// dagger_beta, dagger_epochs, evaluate_every; teacher forcing is round 0,
// beta = 1):
//
//  - Collection: the agent (rollout/WaypointAgent.h) runs the round's
//    episodes on trainer.num_envs environments; at every decision the
//    oracle labels the candidates (waypoint::oracleChoice(): the one whose
//    approach ends nearest the goal by geodesic distance, or STOP), the agent
//    takes the oracle's choice with probability beta, else its own (sampled
//    with trainer.dagger_action: sample), and records what it saw. The
//    decisions of every round stay in memory (features as fp16: about
//    N * (F_rgb + F_depth) * 2 bytes per decision) and are aggregated.
//  - Learning: cross-entropy of the policy's logits (STOP and the
//    candidates) against the labels over whole decision sequences,
//    batches of trainer.batch_size episodes, Adam at trainer.lr; plus
//    trainer.instruction_contrast_weight times instructionContrastLoss(),
//    plus waypoint_agent.sub_instruction_weight times subInstructionLoss().
//  - After each epoch: a checkpoint (ckpt.<i>.pth, the policy's tensors
//    only; the encoders and the predictor are frozen files named by the
//    config) and, as the schedule says, an evaluation on eval.splits
//    (eval.train_eval_episodes each) through the trainer's validation
//    (train/PeriodicEvaluator.h), the best by eval.selection_split SPL in
//    checkpoints/best.json. `eval` scores the checkpoints like any other.
//
// train --resume is refused: a run is minutes long on the default world.

#include <filesystem>
#include <map>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "data/SubInstructions.h"
#include "models/ObservationEncoder.h"
#include "models/WaypointCmaPolicy.h"
#include "models/WaypointPredictor.h"
#include "rollout/WaypointAgent.h"
#include "train/ExperimentConfig.h"
#include "train/TrainingData.h"

namespace vln::train {

/// Checks what the YAML bounds cannot: the panorama (sim::
/// checkPanoramaConfig()), its image sizes equal to the model's, frozen
/// encoders, token instructions, 120 divisible by the views. Throws
/// std::invalid_argument naming the key.
void validateWaypointAgentConfig(const ExperimentConfig& config);

/// The networks of a waypoint agent built from `config` under
/// trainer.seed: the policy (initialised, GloVe copied in), the frozen
/// encoders with their weight files, the predictor with
/// waypoint_agent.predictor_weights (none with candidates: depth_baseline).
struct WaypointAgentModels {
  std::shared_ptr<models::WaypointCmaPolicyImpl> policy;
  models::ObservationEncoder encoder{nullptr};
  models::WaypointPredictor predictor{nullptr};
  /// More policies that vote with `policy` (addEnsembleMembers()); empty
  /// outside an ensemble.
  std::vector<std::shared_ptr<models::WaypointCmaPolicyImpl>> ensemble;
};
/// `withEmbeddings`: copy dataset.embeddings into the policy (a new run;
/// a checkpoint brings its own).
WaypointAgentModels makeWaypointAgentModels(const ExperimentConfig& config,
                                            bool withEmbeddings);

/// Adds to `models.ensemble` one policy built from `config` per entry of
/// `checkpoints`, loaded with its tensors (readPolicyWeights(): a
/// checkpoint file, or a run directory's best checkpoint): policies of the
/// same recipe trained under other seeds, which then read the same frozen
/// encoders and predictor as `models.policy` (rollout::NativeWaypointModel
/// averages their choice probabilities). Throws naming the file when its
/// tensors do not fit model.*.
void addEnsembleMembers(WaypointAgentModels& models,
                        const ExperimentConfig& config,
                        std::span<const std::filesystem::path> checkpoints);

/// An agent over `models` (an ensemble when models.ensemble is not empty)
/// with `numEnvs` environments, non-maximum suppression from
/// waypoint.nms_*.
std::unique_ptr<rollout::WaypointAgent> makeWaypointAgent(
    const ExperimentConfig& config, const WaypointAgentModels& models,
    int numEnvs, bool sampleActions, uint64_t seed);

/// The imitation loss over accepted sets: with `logits` [D, C], `labels`
/// [D] (-1 where unlabelled, such decisions are left out) and `acceptable`
/// [D, C] bool (every labelled row holds its label), -log of the
/// probability the policy gives the row's accepted choices, averaged over
/// the labelled rows. Where every row accepts its label alone this is the
/// cross-entropy (computed as such). A differentiable 0 when no row is
/// labelled.
torch::Tensor acceptedSetLoss(const torch::Tensor& logits,
                              const torch::Tensor& labels,
                              const torch::Tensor& acceptable);

/// The instruction-contrast loss of one batch: its decisions (`inputs`,
/// [T, B] as forwardSequence() takes them) replayed with each episode's
/// instruction swapped for the next one's in `instructions` (B episodes,
/// cyclically); with `logits` [T * B, 1 + K] the policy's outputs under the
/// episodes' own instructions and `labels` [T * B] the oracle's choices (-1
/// where unlabelled), softplus(log p_swapped(label) - log p_own(label))
/// averaged over the labelled decisions. ln 2 when the choices do not
/// depend on the words; lower only when the episode's own words make the
/// oracle's choice more likely than another episode's do. Only a policy
/// that reads the instruction can lower it, which the cross-entropy alone
/// does not demand when most labels can be guessed from the views
/// (docs/waypoints.md).
torch::Tensor instructionContrastLoss(
    models::WaypointCmaPolicyImpl& policy,
    const models::WaypointPolicyInputs& inputs, const torch::Tensor& logits,
    const torch::Tensor& labels,
    const std::vector<const data::Episode*>& instructions, int maxLength,
    const torch::Device& device);

/// Per episode of `splits`, its sub-instructions as token ranges (data::
/// subInstructionTokens()), read from each split's
/// <split>_sub_instructions.json.gz under dataset.data_path and checked
/// against the split (data::checkSubInstructions()). Throws
/// std::invalid_argument naming `option` (what needs them) and the file
/// when one is missing.
using SubInstructionTokensByEpisode = rollout::EpisodeClauses;
SubInstructionTokensByEpisode loadEpisodeClauses(
    const ExperimentConfig& config, std::span<const data::Split* const> splits,
    std::string_view option);
/// loadEpisodeClauses() of the training pool's splits (train, the aug
/// split, the extra splits), naming the option that needs them
/// (waypoint_agent.sub_instruction_weight, leg_words_only or
/// model.clause_tracker).
SubInstructionTokensByEpisode loadSubInstructionTokens(
    const ExperimentConfig& config, const TrainingData& data);
/// With waypoint_agent.leg_words_only, hands `agent` the clauses of
/// `split`'s episodes (loadEpisodeClauses()); nothing otherwise.
void readSplitLegWords(rollout::WaypointAgent& agent,
                       const ExperimentConfig& config,
                       const data::Split& split);

/// The tokens the sub-instruction loss asks decision t of batch episode b
/// (`rows[b]`, the instruction of `episodes[b]`) to attend to: the tokens
/// of the clauses the agent was to follow next where it stood
/// (data::clausesAhead()).
/// [T, B, L] float 0/1 with T the longest row; all zero at padding steps,
/// for episodes without sub-instructions and where the clauses' tokens lie
/// beyond the first `L`.
at::Tensor subInstructionTargets(
    std::span<const std::vector<rollout::WaypointDecision>* const> rows,
    std::span<const data::Episode* const> episodes,
    const SubInstructionTokensByEpisode& tokens, int64_t L);

/// model.clause_tracker's targets: for decision t of batch episode b
/// (`rows[b]`, the instruction of `episodes[b]`), the rule clause
/// (data::ruleClauses() of its instruction_text) holding the first word of
/// the clauses it was to follow next where it stood (data::clausesAhead()
/// of its sub-instructions `tokens`), the last rule clause where none is
/// ahead. long [T, B], T the longest row, -1 at padding steps. Throws
/// std::invalid_argument for an episode missing from `tokens`.
at::Tensor clauseTargets(
    std::span<const std::vector<rollout::WaypointDecision>* const> rows,
    std::span<const data::Episode* const> episodes,
    const SubInstructionTokensByEpisode& tokens);

/// -log of the instruction attention's mass on the targets (`attention`
/// and `targets` [T, B, L]), averaged over the decisions that have a
/// target; a differentiable 0 when none has.
torch::Tensor subInstructionLoss(const torch::Tensor& attention,
                                 const torch::Tensor& targets);

/// The progress monitor's targets [T, B] for `rows` (T the longest row):
/// progressTarget() of each decision's goal_distance against its episode's
/// info.geodesic_distance (clipped to [-1, 1] with `clip`); 0 at padding
/// steps and where either distance is unknown.
at::Tensor progressTargets(
    std::span<const std::vector<rollout::WaypointDecision>* const> rows,
    std::span<const data::Episode* const> episodes, bool clip);

/// trainer.task = waypoint_cma. Expects logging set up.
void runWaypointAgentTraining(const ExperimentConfig& config,
                              const std::filesystem::path& runDir);

}  // namespace vln::train
