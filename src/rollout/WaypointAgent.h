#pragma once
// The waypoint agent (issue 18) as an evaluation Agent: at each decision it
// renders a panorama (sim/Panorama.h), encodes its views with the frozen
// encoders, asks the candidate source (the learned predictor or the
// depth-only baseline) for up to waypoint_agent.max_candidates waypoints,
// and the waypoint CMA (models/WaypointCmaPolicy.h) picks one or STOP. The
// networks are a WaypointDecisionModel: the project's modules, or an
// exported archive (rollout/ScriptedWaypointModel.h) that runs exactly
// where a checkpoint would. By
// default (waypoint_agent.execution walk) the chosen waypoint is executed
// with low-level actions (waypoint::planApproach(): turns, then 0.25 m
// forward steps with collisions and sliding), one per act(), so the
// evaluator, its metrics, the step limit (task.max_episode_steps) and the
// maps see an ordinary low-level agent. With execution teleport, act()
// returns sim::Action::kTeleport once per chosen waypoint and asks the
// environment to place the agent at it (VectorEnv::requestTeleport()):
// one step, snapped to the navmesh on the agent's island or refused, and
// recorded like any other step. After waypoint_agent.max_decisions
// decisions the agent STOPs.
//
// For training (train/WaypointAgentTrainer.h) the agent also labels every
// decision with the oracle (waypoint::oracleChoice()), follows it with
// probability beta (DAgger), and records what the policy saw: the views'
// features (fp16), the candidates, the previous decision and the label.
//
// Batching does not change behaviour: instructions are encoded per
// episode, recurrent state is per environment, and draws come from a
// per-episode generator (common::episodeSeed()).

#include <ATen/core/Tensor.h>

#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <span>
#include <vector>

#include "data/SubInstructions.h"
#include "models/Policy.h"
#include "rollout/Agent.h"
#include "rollout/WaypointAgentConfig.h"
#include "rollout/WaypointDecisionModel.h"
#include "sim/Panorama.h"
#include "waypoint/WaypointHeatmap.h"

namespace vln::rollout {

/// One decision as the policy saw it, with the oracle's label.
struct WaypointDecision {
  at::Tensor rgb;    ///< [N, F_rgb] fp16 on the CPU; undefined with no_rgb
  at::Tensor depth;  ///< [N, F_depth] fp16; undefined with no_depth
  std::vector<waypoint::Candidate> candidates;  ///< at most max_candidates
  float prev_heading = 0.0f;   ///< the previous decision's candidate
  float prev_distance = 0.0f;  ///< (0 at the first decision)
  int label = 0;               ///< oracle: 0 STOP, j + 1 candidate j
  /// The choices the loss accepts, as bits in the label's coding
  /// (waypoint::acceptableChoices() with waypoint_agent.label_tolerance);
  /// 0 means the label alone.
  uint32_t acceptable = 0;
  int taken = 0;               ///< what the agent did, same coding
  /// Where the agent stood (world frame, metres), e.g. to tell which leg of
  /// the reference path it was about to walk (data::upcomingLeg()).
  Vec3f position = Vec3f::Zero();
  /// The geodesic distance (m) from there to the episode's goal, e.g. for
  /// the progress monitor's target; infinity where unknown or unreachable.
  float goal_distance = std::numeric_limits<float>::infinity();
  /// The features of the mirrored panorama (mirrorPanoramaViews()), kept
  /// when collecting with WaypointCollection::mirror; else undefined.
  at::Tensor rgb_mirrored;
  at::Tensor depth_mirrored;
};

/// Training-time behaviour (WaypointAgent::collect()).
struct WaypointCollection {
  double beta = 1.0;   ///< probability of taking the oracle's choice
  bool sample = true;  ///< otherwise sample the policy (else its argmax)
  uint64_t seed = 0;   ///< of the per-episode draws
  /// Also encode each decision's mirrored panorama (for mirroredDecision()).
  bool mirror = false;
};

/// Per episode, its sub-instructions as token ranges
/// (data::subInstructionTokens()), for waypoint_agent.leg_words_only.
using EpisodeClauses =
    std::map<const data::Episode*, std::vector<data::SubInstructionTokens>>;

class WaypointAgent : public Agent {
 public:
  /// `agent` is the low-level action space (sim.agent). Throws
  /// std::invalid_argument when waypoint_agent.candidates is predictor and
  /// `model` proposes none, or `panorama` has other views than it reads.
  WaypointAgent(std::unique_ptr<WaypointDecisionModel> model,
                const WaypointAgentConfig& config,
                const sim::PanoramaConfig& panorama,
                const sim::AgentConfig& agent, int numEnvs, bool sampleActions,
                uint64_t seed);
  /// The project's modules (NativeWaypointModel); `predictor` may be null
  /// with candidates: depth_baseline.
  WaypointAgent(std::shared_ptr<models::WaypointCmaPolicyImpl> policy,
                models::ObservationEncoder encoder,
                models::WaypointPredictor predictor, CandidateNms nms,
                const WaypointAgentConfig& config,
                const sim::PanoramaConfig& panorama,
                const sim::AgentConfig& agent, int numEnvs, bool sampleActions,
                uint64_t seed, int maxInstructionLength);
  ~WaypointAgent() override;

  /// Label every decision with the oracle, follow it with probability
  /// `collection.beta` and record the decisions (takeDecisions()).
  void collect(const WaypointCollection& collection);
  /// With waypoint_agent.leg_words_only: the clauses of every episode the
  /// agent will be reset to (keyed by the episode objects reset() is given)
  /// and the instruction length cap (dataset.max_instruction_length). Each
  /// decision's policy then reads only data::clausesAhead()'s words (all of
  /// them where none is ahead). reset() throws std::invalid_argument for an
  /// episode without clauses.
  void readLegWordsOnly(EpisodeClauses clauses, int maxInstructionLength);

  void reset(int env, const data::Episode& episode) override;
  std::vector<sim::Action> act(VectorEnv& envs,
                               std::span<const int> active) override;
  bool needsObservations() const override { return false; }

  /// The decisions recorded in environment `env` since its reset() (with
  /// collect()), moved out.
  std::vector<WaypointDecision> takeDecisions(int env);
  /// Decisions made in `env`'s current episode.
  int decisions(int env) const;
  std::vector<WaypointChoice> waypointChoices(int env) const override;

 private:
  struct Slot;
  void decide(VectorEnv& envs, std::span<const int> deciding);
  // with view_labels: the views' labels of environments `envList` (row i is
  // envList[i]), [n, N, world::viewLabelSize()] float
  at::Tensor viewLabels(VectorEnv& envs, std::span<const int> envList);

  std::unique_ptr<WaypointDecisionModel> model_;
  WaypointAgentConfig config_;
  sim::PanoramaConfig panorama_;
  sim::AgentConfig agent_;
  bool sample_;
  uint64_t seed_;
  bool collecting_ = false;
  WaypointCollection collection_;
  std::vector<std::unique_ptr<Slot>> slots_;
  EpisodeClauses legClauses_;
  int legWordsWidth_ = 0;
};

/// The recorded episodes `episodes` (each a decision sequence, in order) as
/// one training batch: WaypointPolicyInputs [T, B, ...] with T the longest
/// episode and K = `maxCandidates` slots, padded after each episode's end
/// (not_done 0, no candidates), features as float; labels [T, B] int64
/// with -1 on the padding; acceptable [T, B, K + 1] bool, the choices the
/// loss accepts (the label alone where a decision's `acceptable` is 0;
/// none on the padding).
struct WaypointBatch {
  models::WaypointPolicyInputs inputs;
  at::Tensor labels;
  at::Tensor acceptable;
};
WaypointBatch batchDecisions(
    std::span<const std::vector<WaypointDecision>* const> episodes,
    int maxCandidates);

/// A panorama's images [n, N, h, w, c] as the agent's mirror image would
/// see them: view k looks k * 2 pi / N to the left, so the mirrored view k
/// is view (N - k) mod N flipped left to right.
at::Tensor mirrorPanoramaViews(const at::Tensor& images);

/// `decision` in the mirror image of its scene: the mirrored panorama's
/// features, every heading (candidates', the previous decision's) negated,
/// the same label. Its instruction must be read with "left" and "right"
/// swapped (swapLeftAndRight()). Throws std::invalid_argument when the
/// decision was collected without WaypointCollection::mirror.
WaypointDecision mirroredDecision(const WaypointDecision& decision);

/// Token rows [B, L] with the ids `left` and `right` exchanged in the rows
/// where `rows[b]` is true (a copy).
at::Tensor swapLeftAndRight(const at::Tensor& tokens,
                            const std::vector<bool>& rows, int64_t left,
                            int64_t right);

}  // namespace vln::rollout
