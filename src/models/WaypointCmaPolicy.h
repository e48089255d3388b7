#pragma once
// The cross-modal attention agent over candidate waypoints (issue 18), after
// Hong et al.'s CMA with a waypoint predictor (CVPR 2022, "Bridging the Gap
// Between Learning in Discrete and Continuous Environments for VLN") and
// the paper's CMA (CmaPolicy.h): at each decision the agent sees a panorama
// of N views and up to K candidate waypoints, and picks one or STOP.
//
//   e_k   = W_e [rgb_k', depth_k', sin, cos of view k's heading]   views
//   h1_t  = GRU1([mean_k e_k, a_{t-1}])
//   s_t   = Attn(S, W_s h1_t)                     instruction (as CmaPolicy)
//   v_t   = Attn(E_t, W_t s_t)                    views
//   h2_t  = GRU2(ReLU(W_c [h1_t, s_t, v_t, a_{t-1}]))
//   c_j   = W_c' [e_{view(j)}, sin, cos, dist / 3]  candidate j, in the view
//           nearest its heading; c_0 = a learned STOP key
//   logit_j = (W_q [h2_t, s_t, v_t]) . c_j / sqrt(H), -inf where masked
// with rgb_k' = ReLU(W_r rgb_k), depth_k' = ReLU(W_d depth_k) of the
// flattened frozen encoder features, and a_{t-1} = ReLU(W_a [sin, cos,
// dist / 3, start]) of the previous decision's candidate (relative heading
// and distance when it was chosen; zeros and start = 1 at t = 0).
// With model.leg_attention a second attention over the instruction,
//   l_t   = Attn(S, W_l h1_t)
// joins s_t wherever s_t is an input (GRU2's and the query's), as a place
// for the words of the leg at hand (waypoint_agent.sub_instruction_weight
// supervises it then, not s_t; measured and not adopted: docs/results.md,
// "Sub-instruction attention, and the mirrored DAgger round's third seed").
// With model.candidate_text each candidate also reads the instruction,
//   w_j   = Attn(S, W_w c_j),   c_j <- c_j + W_u w_j
// before the logits, so that the words describing a candidate (a landmark
// in its view, a turn towards its heading) reach its key directly
// (measured and not adopted: docs/results.md, "Candidates that read the
// words, a slower learning rate and the better RGB encoder again").
// With model.clause_tracker the instruction is cut into clauses by a rule
// (data::ruleClauses(); r_j = W_r of the mean encoded word of clause j) and
// a pointer p_t moves along them, never back:
//   z_t(a) = w_z . tanh(W_z h1_t + r_{p_{t-1} + a} + E_a),  a = 0, 1, 2
//   p_t    = p_{t-1} + argmax_a z_t(a)       (p_{-1} = clause_start)
// or, in training, the oracle's clause where an episode follows it; s_t
// (and l_t) then attend only to the words of clauses p_t .. p_t +
// model.clause_window - 1. The head reads h1_t, which has not read the
// words, so its logits need no mask; the trainer fits z_t to the advance
// that reaches the oracle's clause (waypoint_agent.clause_tracker_weight).
// With model.clause_tracker_memory the head also reads GRU2's state after
// the previous decision, W_m h2_{t-1} joining W_z h1_t: what the words the
// previous pointer chose made of the last decision. A training sequence
// then runs its decisions one at a time (as step mode does).
// With model.goal_match the RGB features are label probabilities (the
// semantic heads', or the views' true labels) and reach the policy only
// as their match with the labels the goal clause names: per view k and
// group g (category, colour, room) m_kg = max over the named labels of g
// of the view's probability, and n_g = 1 if the clause names one of g;
// [m_k, n] joins view k's depth features, and the STOP key becomes
//   stop_key + W_g [max_k m_k, n]
// so that the views that show the goal, and being where one does, can be
// told apart without learning which word names which label.
// With model.heading_harmonics = M > 1 every "sin, cos" above is sin, cos
// of m times the heading for m = 1 .. M (measured and not adopted:
// docs/results.md, "Four more levers for the waypoint agent").
//
// Sequence mode (training): inputs [T, B, ...]; step mode (acting):
// [B, ...]. Headings are radians counter-clockwise relative to the agent's
// heading when the panorama was taken (waypoint/WaypointHeatmap.h); view k
// looks k * 2*pi/N to the left. Index 0 of the logits is STOP, index j >= 1
// candidate j - 1.
//
// model.dropout (training only, as PolicyImpl's): on the encoded
// instruction, on the encoders' view features and on the query's input.
// With model.progress_monitor a head reads GRU2's state,
//   p_t   = tanh(W_p h2_t)
// trained towards the progress made to the goal (the paper's progress
// monitor, Ma et al. 2019; waypoint_agent training only, not exported).

#include <torch/torch.h>

#include "models/InstructionEncoder.h"
#include "models/MaskedGru.h"
#include "models/ModelConfig.h"
#include "models/Policy.h"

namespace vln::models {

struct WaypointPolicyInputs {
  torch::Tensor rgb;    ///< [.., N, F_rgb] float; undefined with no_rgb
  torch::Tensor depth;  ///< [.., N, F_depth] float; undefined with no_depth
  /// [.., K, 2] float: relative heading (rad), distance (m) of each
  /// candidate slot (anything where the mask is false)
  torch::Tensor candidates;
  torch::Tensor candidate_mask;  ///< [.., K] bool, true at real candidates
  torch::Tensor prev;            ///< [.., 2] heading, distance of a_{t-1}
  torch::Tensor not_done;        ///< [..] float 0/1, 0 at an episode's start
  /// [.., L'] bool, optional: the words each decision may read (true), its
  /// first L columns against an instruction of L tokens (L' >= L); every
  /// word when undefined, and where a decision's row allows none of its
  /// instruction's words. What waypoint_agent.leg_words_only feeds.
  torch::Tensor text_mask = {};
  /// With model.clause_tracker: long [B, L'], the rule clause of each of an
  /// episode's tokens (its index in data::ruleClauses(), -1 for none), one
  /// row per episode (not per step), its first L columns read.
  torch::Tensor clause_of_token = {};
  /// With model.clause_tracker: long [B], the pointer before the first step
  /// (the clause the previous decision read); zeros when undefined.
  torch::Tensor clause_start = {};
  /// With model.clause_tracker, optional (training): long [.., ] the clause
  /// each step is to read (the oracle's), and bool [B] the episodes that
  /// read it; the others, and every episode when these are undefined, read
  /// their own pointer.
  torch::Tensor clause_targets = {};
  torch::Tensor clause_teacher = {};
  /// With model.goal_match: float [B, F_rgb], one row per episode, the
  /// label group world::goalLabels() gives each of the RGB features (0 for
  /// a label the goal clause does not name, 1 category, 2 colour, 3 room).
  torch::Tensor goal_labels = {};
};

struct WaypointPolicyOutputs {
  torch::Tensor logits;  ///< [.., 1 + K]: STOP, then the candidates
  torch::Tensor hidden;  ///< [B, 2, hidden_size] after the last step
  torch::Tensor progress;  ///< [..] in (-1, 1) with model.progress_monitor
  /// [.., L]: the instruction attention of s_t (weights over the tokens),
  /// or with model.leg_attention that of l_t; undefined with
  /// model.no_instruction
  torch::Tensor text_attention;
  /// With model.clause_tracker: [.., kClauseAdvances] the head's logits of
  /// advancing 0, 1, 2 clauses from clause_before (-inf past the last
  /// clause); long [..] the pointer before each step and the clause the
  /// step read.
  torch::Tensor clause_logits;
  torch::Tensor clause_before;
  torch::Tensor clause_pointer;
  /// With clause_targets: they, within the clauses of the words read (the
  /// last one for a target past them; -1 stays -1).
  torch::Tensor clause_targets;
};

/// How many clauses the clause tracker's pointer can advance at a decision,
/// plus one (staying): a waypoint is a few metres, at most two clauses'
/// worth of path.
inline constexpr int64_t kClauseAdvances = 3;

/// model.goal_match's label groups: categories, colours, rooms (the values
/// 1, 2, 3 of goal_labels).
inline constexpr int64_t kGoalGroups = 3;

class WaypointCmaPolicyImpl : public torch::nn::Module {
 public:
  /// Sizes from `config` (hidden_size, rgb/depth_projection_size,
  /// prev_action_embedding_dim, the instruction encoder's; no_rgb,
  /// no_depth, no_instruction); `rgbFeatures` / `depthFeatures` are the
  /// flattened encoder features of one view (rgbFeatureShape(),
  /// depthFeatureShape()), `numViews` the panorama's views.
  WaypointCmaPolicyImpl(const ModelConfig& config, int64_t numViews,
                        int64_t rgbFeatures, int64_t depthFeatures);

  /// Token ids [B, L] (PAD 0) -> the encoded instruction (keys, states,
  /// mask); empty when model.no_instruction.
  EncodedInstruction encodeInstruction(const torch::Tensor& tokens);

  /// Sequence mode: inputs [T, B, ...], hidden [B, 2, H] before t = 0.
  WaypointPolicyOutputs forwardSequence(const EncodedInstruction& instruction,
                                        const WaypointPolicyInputs& inputs,
                                        const torch::Tensor& hidden);
  /// Step mode: inputs [B, ...].
  WaypointPolicyOutputs step(const EncodedInstruction& instruction,
                             const WaypointPolicyInputs& inputs,
                             const torch::Tensor& hidden);

  torch::Tensor initialHidden(int64_t batch) const;
  /// Copies GloVe [vocab_size, embedding_dim] into the instruction encoder.
  void setWordEmbeddings(const torch::Tensor& matrix);

  const ModelConfig& config() const { return config_; }
  int64_t numViews() const { return numViews_; }
  /// The flattened encoder features of one view the policy reads (the
  /// constructor's rgbFeatures, depthFeatures; with model.goal_match the
  /// RGB labels, which no projection's width gives).
  int64_t rgbFeatures() const { return rgbFeatures_; }
  int64_t depthFeatures() const { return depthFeatures_; }

  InstructionEncoder instruction_encoder{nullptr};
  torch::nn::Linear rgb_linear{nullptr}, depth_linear{nullptr};
  torch::nn::Linear view_linear{nullptr};
  torch::nn::Linear prev_linear{nullptr};
  MaskedGru state_encoder{nullptr};
  torch::nn::Linear state_q{nullptr}, text_k{nullptr}, text_q{nullptr};
  torch::nn::Linear leg_q{nullptr};  ///< with model.leg_attention
  /// W_w, W_u with model.candidate_text
  torch::nn::Linear candidate_text_q{nullptr}, candidate_text_linear{nullptr};
  torch::Tensor visual_query;  ///< [hidden] with no_instruction
  torch::nn::Linear second_state_compress{nullptr};
  MaskedGru second_state_encoder{nullptr};
  torch::nn::Linear candidate_linear{nullptr};
  torch::Tensor stop_key;  ///< [hidden]
  torch::nn::Linear query_linear{nullptr};
  torch::nn::Linear progress_monitor{nullptr};  ///< W_p [1, hidden]
  /// W_z, W_r, E_a, w_z with model.clause_tracker
  torch::nn::Linear clause_hidden{nullptr}, clause_text{nullptr};
  torch::Tensor clause_advance;  ///< [kClauseAdvances, hidden]
  torch::nn::Linear clause_score{nullptr};
  torch::nn::Linear clause_memory{nullptr};  ///< W_m, clause_tracker_memory
  torch::nn::Linear goal_stop{nullptr};      ///< W_g, model.goal_match

 private:
  // x, or x with model.dropout applied while training
  torch::Tensor trainingDropout(const torch::Tensor& x);
  // views [n, N, H] from the features of n steps
  torch::Tensor encodeViews(const WaypointPolicyInputs& inputs, int64_t n,
                            const torch::Tensor& goal);
  // model.goal_match's [m_k, n] for each of the n = steps * batch rows'
  // views: [n, N, 2 * kGoalGroups]
  torch::Tensor matchGoal(const WaypointPolicyInputs& inputs, int64_t steps,
                          int64_t batch) const;
  // model.clause_tracker over `steps` steps of `batch` episodes from GRU1's
  // states h1 [steps * batch, H] (and with clause_tracker_memory, one step,
  // GRU2's state before it, h2Before [batch, H]): fills `out`'s clause
  // outputs ([steps, batch, ..]) and returns the words each step reads,
  // bool [n, L]
  torch::Tensor trackClauses(const EncodedInstruction& instruction,
                             const WaypointPolicyInputs& inputs,
                             const torch::Tensor& h1,
                             const torch::Tensor& h2Before, int64_t steps,
                             int64_t batch, WaypointPolicyOutputs& out);
  // forwardSequence() one decision at a time (clause_tracker_memory)
  WaypointPolicyOutputs forwardStepwise(const EncodedInstruction& instruction,
                                        const WaypointPolicyInputs& inputs,
                                        const torch::Tensor& hidden);

  ModelConfig config_;
  int64_t numViews_;
  int64_t rgbFeatures_;
  int64_t depthFeatures_;
};
TORCH_MODULE(WaypointCmaPolicy);

}  // namespace vln::models
