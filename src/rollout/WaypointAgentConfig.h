#pragma once
// Settings of the waypoint agent (rollout/WaypointAgent.h) and its training
// (trainer.task = waypoint_cma, train/WaypointAgentTrainer.h): YAML section
// `waypoint_agent:`. No LibTorch.

#include <string>

#include "common/Config.h"
#include "waypoint/DepthWaypointBaseline.h"
#include "waypoint/WaypointApproach.h"

namespace vln::rollout {

struct WaypointAgentConfig {
  /// Where the candidates come from: the learned predictor (its weights in
  /// predictor_weights, its network as `waypoint.predictor`, non-maximum
  /// suppression as `waypoint.nms_*`) or the depth-only baseline.
  std::string candidates = "predictor";
  std::string predictor_weights =
      "runs/waypoint/predictor/waypoint_predictor.pt";
  /// Candidate slots of the policy (more candidates are dropped, the
  /// lowest scores first).
  int max_candidates = 5;
  /// Decisions per episode; the agent STOPs at the next one.
  int max_decisions = 15;
  /// How a chosen waypoint is executed: walked with low-level actions
  /// (waypoint::planApproach()), or one teleport step
  /// (waypoint::teleportTarget(), sim::resolveTeleport()).
  waypoint::Execution execution = waypoint::Execution::kWalk;
  /// What the training oracle aims for: the episode's goal, or the next
  /// reference-path waypoint not yet within stop_distance (then the goal),
  /// or (goal_near_path) the goal by way of the candidates that end within
  /// oracle_corridor of the reference path (waypoint::PathCorridor; all
  /// candidates where none does).
  std::string oracle = "goal";
  /// Metres from the reference path's segments, for oracle goal_near_path.
  double oracle_corridor = 1.0;
  /// Added to the policy's STOP logit before it chooses (greedy or
  /// sampled): a decision threshold, not a weight. Positive values stop
  /// sooner. The oracle's labels and the training loss do not see it.
  double stop_bias = 0.0;
  /// Training only: the probability that a collected episode is replayed
  /// mirrored in a training batch (rollout::mirroredDecision(), the words
  /// "left" and "right" swapped). Above 0 every collected decision also
  /// keeps the features of its mirrored panorama.
  double mirror_probability = 0.0;
  /// Training only: weight of the sub-instruction loss (train::
  /// subInstructionLoss()), which asks the instruction attention at each
  /// decision to rest on the clauses of the reference path's leg ahead;
  /// needs the training splits' sub-instruction files
  /// (data/SubInstructions.h). 0: off (0.5 and 2 measured and not
  /// adopted: docs/results.md, "Sub-instruction attention ...").
  double sub_instruction_weight = 0.0;
  /// Training only, with model.clause_tracker: weight of the tracker's
  /// cross-entropy towards the advance that reaches the rule clause holding
  /// the first word of data::clausesAhead() (train::clauseTargets()); needs
  /// the training splits' sub-instruction files.
  double clause_tracker_weight = 1.0;
  /// Training only, with model.clause_tracker: probability that an episode
  /// of a batch reads the oracle's clause at every decision rather than
  /// its own pointer's (which it reads at evaluation).
  double clause_teacher_probability = 0.5;
  /// Training only: the loss accepts every candidate whose execution ends
  /// at most this many metres farther from the oracle's target than the
  /// oracle's choice (waypoint::acceptableChoices()): -log of the
  /// probability of the accepted set instead of the label's. 0: the label
  /// alone (cross-entropy).
  double label_tolerance = 0.0;
  /// A diagnostic, not an agent: the policy's RGB features are replaced by
  /// what a perfect recogniser would say each view shows
  /// (world::viewLabelFeatures(): the object categories covering at least
  /// view_label_min_fraction of the view's semantic render, their colours,
  /// the room type under the agent), the targets of the RGB encoder's
  /// semantic pretraining. Needs model.no_rgb false and
  /// model.rgb_semantic_outputs = world::viewLabelSize(); the RGB encoder is
  /// not run, and such a run cannot be exported (an archive sees images).
  bool view_labels = false;
  double view_label_min_fraction = 0.02;
  /// A diagnostic, not an agent: at each decision the policy reads only the
  /// words of the clauses it is to follow next (data::clausesAhead() of the
  /// episode's sub-instructions and reference path at the agent's
  /// position): what knowing exactly where along the instruction it is
  /// would be worth. Needs the split's sub-instruction files (the generator
  /// writes them for evaluation splits with
  /// splits.evaluation_sub_instructions) and cannot be exported.
  bool leg_words_only = false;
  waypoint::ApproachConfig approach;
  waypoint::DepthBaselineConfig depth_baseline;

  void visit(common::ConfigVisitor& v) {
    v.choice("candidates", candidates, {"predictor", "depth_baseline"},
             "Candidate waypoints from the learned predictor "
             "(predictor_weights) or the depth-only baseline");
    v.field("predictor_weights", predictor_weights,
            "Weights of the learned predictor (trainer.task "
            "waypoint_predictor's output), built as waypoint.predictor");
    v.field("max_candidates", max_candidates,
            "Candidates the policy chooses among (besides STOP)",
            common::inRange(1, 120));
    v.field("max_decisions", max_decisions,
            "Waypoint decisions per episode; then the agent STOPs",
            common::inRange(1, 10000));
    v.enumeration("execution", execution,
                  {{"walk", waypoint::Execution::kWalk},
                   {"teleport", waypoint::Execution::kTeleport}},
                  "A chosen waypoint is walked (turns, then forward steps "
                  "with collisions and sliding) or teleported to (one step: "
                  "snapped to the navmesh on the agent's island, else the "
                  "agent stays)");
    v.choice("oracle", oracle, {"goal", "reference_path", "goal_near_path"},
             "The training oracle picks the candidate whose approach ends "
             "nearest the goal, or nearest the next reference-path waypoint "
             "not yet reached, or nearest the goal among those ending within "
             "oracle_corridor of the reference path (all where none does)");
    v.field("oracle_corridor", oracle_corridor,
            "Metres from the reference path's segments within which the "
            "goal_near_path oracle prefers its candidates' ends",
            common::inRange(0.0, 100.0));
    v.field("stop_bias", stop_bias,
            "Added to the policy's STOP logit when it chooses (positive "
            "stops sooner; labels and loss are unchanged)",
            common::inRange(-20.0, 20.0));
    v.field("mirror_probability", mirror_probability,
            "Training only: probability that a collected episode is replayed "
            "mirrored in a batch (the panorama's views reversed and each "
            "flipped, headings negated, 'left' and 'right' swapped in the "
            "instruction; labels unchanged). Above 0 collection also encodes "
            "every decision's mirrored panorama",
            common::inRange(0.0, 1.0));
    v.field("sub_instruction_weight", sub_instruction_weight,
            "Training only: weight of the loss that asks the instruction "
            "attention at each decision to rest on the clauses describing the "
            "reference path's leg ahead (from <split>_sub_instructions.json.gz "
            "of every training split, which vlnce-data generate writes); 0 "
            "turns it off",
            common::inRange(0.0, 100.0));
    v.field("clause_tracker_weight", clause_tracker_weight,
            "Training only, with model.clause_tracker: weight of the "
            "tracker's loss, which asks it to advance its pointer to the "
            "rule clause where the words of the reference path's leg ahead "
            "begin (from the training splits' sub-instruction files)",
            common::inRange(0.0, 100.0));
    v.field("clause_teacher_probability", clause_teacher_probability,
            "Training only, with model.clause_tracker: probability that an "
            "episode of a batch reads the oracle's clause at each decision "
            "instead of its own pointer's (evaluation always reads its own)",
            common::inRange(0.0, 1.0));
    v.field("label_tolerance", label_tolerance,
            "Training only: the loss accepts, besides the oracle's choice, "
            "every candidate whose execution ends at most this many metres "
            "farther from the oracle's target (-log of the accepted set's "
            "probability); 0: the oracle's choice alone",
            common::inRange(0.0, 10.0));
    v.field("view_labels", view_labels,
            "Diagnostic: the policy reads each view's true labels (object "
            "categories in view, their colours, the room type) instead of "
            "the RGB encoder's features; needs model.no_rgb false and "
            "model.rgb_semantic_outputs 50; not exportable");
    v.field("leg_words_only", leg_words_only,
            "Diagnostic: at each decision the policy reads only the words "
            "of the clauses describing the reference path's leg ahead of the "
            "agent (an oracle of where along the instruction it is), in "
            "training and evaluation; needs the splits' sub-instruction "
            "files; not exportable");
    v.field("view_label_min_fraction", view_label_min_fraction,
            "With view_labels: the share of a view's pixels an object must "
            "cover to count as in view",
            common::inRange(0.0, 1.0));
    v.section("approach", approach,
              "Executing a waypoint and the oracle's stopping rule");
    v.section("depth_baseline", depth_baseline,
              "The depth-only candidates (candidates: depth_baseline)");
  }
  bool operator==(const WaypointAgentConfig&) const = default;
};

}  // namespace vln::rollout
