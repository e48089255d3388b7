#include "rollout/WaypointAgent.h"

#include <torch/torch.h>

#include <algorithm>
#include <cstring>

#include "common/Check.h"
#include "common/Random.h"
#include "rollout/ObservationBatch.h"
#include "rollout/PolicyAgent.h"
#include "rollout/RecurrentState.h"
#include "sim/Simulator.h"
#include "waypoint/DepthWaypointBaseline.h"
#include "waypoint/WaypointApproach.h"
#include "world/ViewLabels.h"

namespace vln::rollout {

struct WaypointAgent::Slot {
  const data::Episode* episode = nullptr;
  std::vector<sim::Action> queue;
  size_t next = 0;
  sim::AgentState teleport;  // the target of a queued kTeleport
  int decisions = 0;
  float prevHeading = 0.0f;
  float prevDistance = 0.0f;
  int referenceIndex = 1;  // oracle: reference_path's next waypoint
  // with leg_words_only: the episode's clauses
  const std::vector<data::SubInstructionTokens>* clauses = nullptr;
  std::vector<WaypointDecision> record;
  std::vector<WaypointChoice> choices;
  EpisodeDraws draws;
  sim::Panorama panorama;
  // with view_labels: the scene the labels were last taken in and its
  // renderer (declared after the scene it reads, so destroyed before it)
  std::shared_ptr<const sim::Scene> labelScene;
  std::unique_ptr<sim::Renderer> labelRenderer;
};

WaypointAgent::WaypointAgent(std::unique_ptr<WaypointDecisionModel> model,
                             const WaypointAgentConfig& config,
                             const sim::PanoramaConfig& panorama,
                             const sim::AgentConfig& agent, int numEnvs,
                             bool sampleActions, uint64_t seed)
    : model_(std::move(model)),
      config_(config),
      panorama_(panorama),
      agent_(agent),
      sample_(sampleActions),
      seed_(seed) {
  VLN_CHECK_ARG(model_ != nullptr, "WaypointAgent: no model");
  VLN_CHECK_ARG(numEnvs >= 1, "WaypointAgent: numEnvs must be >= 1");
  VLN_CHECK_ARG(config.candidates != "predictor" || model_->proposes(),
                "WaypointAgent: waypoint_agent.candidates is predictor but no "
                "predictor was given");
  VLN_CHECK_ARG(panorama.num_views == model_->numViews(),
                "WaypointAgent: panorama.num_views is ", panorama.num_views,
                ", the policy reads ", model_->numViews(), " views");
  VLN_CHECK_ARG(!config.view_labels || (model_->config().usesRgb() &&
                                        model_->config().rgb_semantic_outputs ==
                                            world::viewLabelSize()),
                "WaypointAgent: waypoint_agent.view_labels needs a policy "
                "reading RGB features of ",
                world::viewLabelSize(), " numbers per view");
  for (int i = 0; i < numEnvs; ++i) slots_.push_back(std::make_unique<Slot>());
}

WaypointAgent::WaypointAgent(
    std::shared_ptr<models::WaypointCmaPolicyImpl> policy,
    models::ObservationEncoder encoder, models::WaypointPredictor predictor,
    CandidateNms nms, const WaypointAgentConfig& config,
    const sim::PanoramaConfig& panorama, const sim::AgentConfig& agent,
    int numEnvs, bool sampleActions, uint64_t seed, int maxInstructionLength)
    : WaypointAgent(std::make_unique<NativeWaypointModel>(
                        std::move(policy), std::move(encoder),
                        std::move(predictor), nms, maxInstructionLength),
                    config, panorama, agent, numEnvs, sampleActions, seed) {}

WaypointAgent::~WaypointAgent() = default;

void WaypointAgent::collect(const WaypointCollection& collection) {
  collecting_ = true;
  collection_ = collection;
}

void WaypointAgent::readLegWordsOnly(EpisodeClauses clauses,
                                     int maxInstructionLength) {
  VLN_CHECK_ARG(maxInstructionLength >= 1,
                "WaypointAgent::readLegWordsOnly(): maxInstructionLength must "
                "be at least 1, got ",
                maxInstructionLength);
  legClauses_ = std::move(clauses);
  legWordsWidth_ = maxInstructionLength;
}

void WaypointAgent::reset(int env, const data::Episode& episode) {
  VLN_CHECK_ARG(env >= 0 && env < static_cast<int>(slots_.size()),
                "WaypointAgent::reset(): environment ", env, " out of range");
  Slot& slot = *slots_[static_cast<size_t>(env)];
  slot.episode = &episode;
  slot.queue.clear();
  slot.next = 0;
  slot.decisions = 0;
  slot.prevHeading = slot.prevDistance = 0.0f;
  slot.referenceIndex = 1;
  slot.record.clear();
  slot.choices.clear();
  slot.draws.restart(collecting_ ? collection_.seed : seed_, episode);
  if (collecting_)
    VLN_CHECK_ARG(!episode.goals.empty(), "WaypointAgent: episode ",
                  episode.episode_id, " has no goal for the oracle");
  slot.clauses = nullptr;
  if (config_.leg_words_only) {
    const auto it = legClauses_.find(&episode);
    VLN_CHECK_ARG(it != legClauses_.end(),
                  "WaypointAgent: waypoint_agent.leg_words_only: no "
                  "sub-instructions for episode ",
                  episode.episode_id, " (readLegWordsOnly())");
    slot.clauses = &it->second;
  }
  model_->reset(env, episode);
}

int WaypointAgent::decisions(int env) const {
  return slots_.at(static_cast<size_t>(env))->decisions;
}

std::vector<WaypointChoice> WaypointAgent::waypointChoices(int env) const {
  return slots_.at(static_cast<size_t>(env))->choices;
}

std::vector<WaypointDecision> WaypointAgent::takeDecisions(int env) {
  return std::move(slots_.at(static_cast<size_t>(env))->record);
}

std::vector<sim::Action> WaypointAgent::act(VectorEnv& envs,
                                            std::span<const int> active) {
  std::vector<int> deciding;
  for (int env : active) {
    VLN_CHECK_ARG(env >= 0 && env < static_cast<int>(slots_.size()) &&
                      slots_[static_cast<size_t>(env)]->episode != nullptr,
                  "WaypointAgent::act(): environment ", env, " not started");
    const Slot& slot = *slots_[static_cast<size_t>(env)];
    if (slot.next >= slot.queue.size()) deciding.push_back(env);
  }
  if (!deciding.empty()) decide(envs, deciding);
  std::vector<sim::Action> actions;
  actions.reserve(active.size());
  for (int env : active) {
    Slot& slot = *slots_[static_cast<size_t>(env)];
    actions.push_back(slot.queue[slot.next++]);
    // the environment executes the teleport as this step
    if (actions.back() == sim::Action::kTeleport)
      envs.requestTeleport(env, slot.teleport);
  }
  return actions;
}

namespace {

// the mirror image's view k is view (N - k) mod N of `views` (view k looks
// k * 2 pi / N to the left): the order of mirrorPanoramaViews() and of
// features that have no side of their own
at::Tensor mirroredViewOrder(int64_t views) {
  return torch::remainder(views - torch::arange(views), views);
}

// the oracle's target: the goal, or with oracle reference_path the next
// reference waypoint not yet within stop_distance (advancing the index)
Vec3f oracleTarget(const WaypointAgentConfig& config,
                   const sim::NavMesh& navmesh, const sim::AgentState& state,
                   const data::Episode& episode, int& referenceIndex,
                   bool& final) {
  final = true;
  if (config.oracle != "reference_path" || episode.reference_path.size() < 2)
    return episode.goals.front().position;
  const auto& path = episode.reference_path;
  while (referenceIndex + 1 < static_cast<int>(path.size()) &&
         navmesh.geodesicDistance(state.position, path[referenceIndex]) <=
             config.approach.stop_distance)
    ++referenceIndex;
  if (referenceIndex + 1 < static_cast<int>(path.size())) {
    final = false;
    return path[static_cast<size_t>(referenceIndex)];
  }
  return episode.goals.front().position;
}

}  // namespace

void WaypointAgent::decide(VectorEnv& envs, std::span<const int> deciding) {
  // episodes out of decisions STOP
  std::vector<int> envList;
  for (int env : deciding) {
    Slot& slot = *slots_[static_cast<size_t>(env)];
    slot.queue.clear();
    slot.next = 0;
    if (slot.decisions >= config_.max_decisions)
      slot.queue.push_back(sim::Action::kStop);
    else
      envList.push_back(env);
  }
  if (envList.empty()) return;
  const auto n = static_cast<int64_t>(envList.size());
  // each deciding environment's row in the batch tensors below
  std::vector<int64_t> rowOf(slots_.size(), -1);
  for (int64_t i = 0; i < n; ++i) rowOf[static_cast<size_t>(envList[i])] = i;

  envs.forEach(envList, [&](int env) {
    envs.simulator(env).observePanorama(
        panorama_, slots_[static_cast<size_t>(env)]->panorama);
  });

  torch::NoGradGuard noGrad;
  const int64_t views = panorama_.num_views;
  const models::ModelConfig& model = model_->config();
  torch::Tensor rgb, depth;
  // with view_labels the policy's RGB features are the views' labels, set
  // below; the encoders see depth alone
  if (model.usesRgb() && !config_.view_labels) {
    const int64_t h = panorama_.rgb.height, w = panorama_.rgb.width;
    rgb = torch::empty({n, views, h, w, 3}, torch::kUInt8);
    for (int64_t i = 0; i < n; ++i) {
      const auto& p = slots_[static_cast<size_t>(envList[i])]->panorama;
      std::memcpy(rgb[i].data_ptr(), p.rgb.data(), p.rgb.size());
    }
  }
  if (model.usesDepth()) {
    const int64_t h = panorama_.depth.camera.height,
                  w = panorama_.depth.camera.width;
    depth = torch::empty({n, views, h, w, 1}, torch::kFloat32);
    for (int64_t i = 0; i < n; ++i) {
      const auto& p = slots_[static_cast<size_t>(envList[i])]->panorama;
      std::memcpy(depth[i].data_ptr(), p.depth.data(),
                  p.depth.size() * sizeof(float));
    }
  }
  PanoramaFeatures features = model_->encode(rgb, depth);
  PanoramaFeatures mirrored;
  if (collecting_ && collection_.mirror)
    mirrored =
        model_->encode(rgb.defined() ? mirrorPanoramaViews(rgb) : rgb,
                       depth.defined() ? mirrorPanoramaViews(depth) : depth);
  if (config_.view_labels) {
    features.rgb = viewLabels(envs, envList);
    // labels have no side: the mirror image only reorders the views
    if (collecting_ && collection_.mirror)
      mirrored.rgb = features.rgb.index_select(1, mirroredViewOrder(views));
  }

  // candidates
  std::vector<std::vector<waypoint::Candidate>> candidates;
  if (config_.candidates == "predictor") {
    candidates = model_->propose(features);
  } else {
    candidates.resize(static_cast<size_t>(n));
    envs.forEach(envList, [&](int env) {
      const auto i = static_cast<size_t>(rowOf[static_cast<size_t>(env)]);
      candidates[i] = waypoint::depthBaselineCandidates(
                          slots_[static_cast<size_t>(env)]->panorama, panorama_,
                          config_.depth_baseline)
                          .candidates;
    });
  }
  const int64_t K = config_.max_candidates;
  for (auto& c : candidates)
    if (static_cast<int64_t>(c.size()) > K) c.resize(static_cast<size_t>(K));

  // the policy's inputs
  auto polar = torch::zeros({n, K, 2});
  auto mask = torch::zeros({n, K}, torch::kBool);
  auto prev = torch::zeros({n, 2});
  auto notDone = torch::zeros({n});
  for (int64_t i = 0; i < n; ++i) {
    const Slot& slot = *slots_[static_cast<size_t>(envList[i])];
    for (size_t j = 0; j < candidates[static_cast<size_t>(i)].size(); ++j) {
      polar[i][static_cast<int64_t>(j)][0] =
          candidates[static_cast<size_t>(i)][j].heading;
      polar[i][static_cast<int64_t>(j)][1] =
          candidates[static_cast<size_t>(i)][j].distance;
      mask[i][static_cast<int64_t>(j)] = true;
    }
    prev[i][0] = slot.prevHeading;
    prev[i][1] = slot.prevDistance;
    notDone[i] = slot.decisions > 0 ? 1.0f : 0.0f;
  }
  // with leg_words_only: the words of the clauses ahead of each agent
  torch::Tensor textMask;
  if (config_.leg_words_only) {
    textMask = torch::zeros({n, legWordsWidth_}, torch::kBool);
    for (int64_t i = 0; i < n; ++i) {
      const Slot& slot = *slots_[static_cast<size_t>(envList[i])];
      for (const data::SubInstructionTokens& c :
           data::clausesAhead(*slot.clauses, slot.episode->reference_path,
                              envs.state(envList[i]).agent.position))
        for (int k = c.first; k < std::min(c.last, legWordsWidth_); ++k)
          textMask[i][k] = true;
    }
  }
  torch::Tensor logits =
      model_->step(envList, features, polar, mask, prev, notDone, textMask);
  if (config_.stop_bias != 0.0) {
    logits = logits.clone();
    logits.select(1, 0).add_(config_.stop_bias);
  }

  // choices (and the oracle's labels), per environment in parallel: the
  // approaches and the oracle plan on the navmesh
  std::vector<int> taken(static_cast<size_t>(n)),
      labels(static_cast<size_t>(n));
  std::vector<uint32_t> acceptable(static_cast<size_t>(n), 0u);
  std::vector<float> goalDistances(static_cast<size_t>(n),
                                   std::numeric_limits<float>::infinity());
  envs.forEach(envList, [&](int env) {
    const int64_t i = rowOf[static_cast<size_t>(env)];
    Slot& slot = *slots_[static_cast<size_t>(env)];
    const sim::NavMesh& navmesh = envs.simulator(env).scene().navmesh();
    const sim::AgentState& state = envs.state(env).agent;
    const auto& cands = candidates[static_cast<size_t>(i)];
    int label = 0;
    if (collecting_) {
      bool final = true;
      const Vec3f target = oracleTarget(config_, navmesh, state, *slot.episode,
                                        slot.referenceIndex, final);
      waypoint::ApproachConfig rule = config_.approach;
      if (!final) rule.success_distance = 0.0f;  // never stop short of the goal
      const waypoint::PathCorridor corridor{
          slot.episode->reference_path,
          static_cast<float>(config_.oracle_corridor)};
      waypoint::OracleVerdict verdict = waypoint::oracleVerdict(
          navmesh, agent_, state, cands, target, rule, config_.execution,
          config_.oracle == "goal_near_path" ? &corridor : nullptr);
      if (verdict.choice < 0 && !final && !cands.empty()) {
        // at an intermediate waypoint with nothing closer: head for the goal
        verdict = waypoint::oracleVerdict(navmesh, agent_, state, cands,
                                          slot.episode->goals.front().position,
                                          config_.approach, config_.execution);
      }
      label = verdict.choice + 1;
      if (!slot.episode->goals.empty())
        goalDistances[static_cast<size_t>(i)] = navmesh.geodesicDistance(
            state.position, slot.episode->goals.front().position);
      if (config_.label_tolerance > 0.0)
        acceptable[static_cast<size_t>(i)] = waypoint::acceptableChoices(
            verdict, static_cast<float>(config_.label_tolerance));
    }
    const bool useOracle =
        collecting_ && common::uniform01(slot.draws.rng) < collection_.beta;
    const int policyChoice = chooseRow(
        logits, i, collecting_ ? collection_.sample : sample_, slot.draws.rng);
    const int choice = useOracle ? label : policyChoice;
    labels[static_cast<size_t>(i)] = label;
    taken[static_cast<size_t>(i)] = choice;
    WaypointChoice mark;
    mark.position = state.position;
    for (const waypoint::Candidate& c : cands)
      mark.candidates.push_back(
          waypoint::fromPolar(state, c.heading, c.distance));
    mark.chosen = choice - 1;
    mark.clause = model_->clauseRead(env);
    if (!collecting_ && !slot.episode->goals.empty()) {
      // the goal oracle's view of the same decision, for analyses of where
      // the agent's choices part from it (what training would label, with
      // the default oracle); collection has its own labels
      const waypoint::OracleVerdict verdict = waypoint::oracleVerdict(
          navmesh, agent_, state, cands, slot.episode->goals.front().position,
          config_.approach, config_.execution);
      mark.oracle = verdict.choice;
      mark.end_distances = verdict.end_distances;
    }
    slot.choices.push_back(std::move(mark));
    if (choice == 0) {
      slot.queue.push_back(sim::Action::kStop);
      return;
    }
    const waypoint::Candidate& c = cands.at(static_cast<size_t>(choice - 1));
    if (config_.execution == waypoint::Execution::kTeleport) {
      slot.teleport = waypoint::teleportTarget(state, c.heading, c.distance);
      slot.queue.push_back(sim::Action::kTeleport);
    } else {
      slot.queue = waypoint::planApproach(navmesh, agent_, state, c.heading,
                                          c.distance, config_.approach)
                       .actions;
    }
  });

  for (int64_t i = 0; i < n; ++i) {
    Slot& slot = *slots_[static_cast<size_t>(envList[i])];
    const int choice = taken[static_cast<size_t>(i)];
    if (collecting_) {
      // row i of a feature tensor as recorded: fp16 on the CPU
      auto recorded = [i](const at::Tensor& t) {
        return t.defined() ? t[i].to(torch::kCPU, torch::kHalf).clone()
                           : at::Tensor();
      };
      WaypointDecision d;
      d.rgb = recorded(features.rgb);
      d.depth = recorded(features.depth);
      d.rgb_mirrored = recorded(mirrored.rgb);
      d.depth_mirrored = recorded(mirrored.depth);
      d.candidates = candidates[static_cast<size_t>(i)];
      d.prev_heading = slot.prevHeading;
      d.prev_distance = slot.prevDistance;
      d.label = labels[static_cast<size_t>(i)];
      d.acceptable = acceptable[static_cast<size_t>(i)];
      d.taken = choice;
      d.position = slot.choices.back().position;
      d.goal_distance = goalDistances[static_cast<size_t>(i)];
      slot.record.push_back(std::move(d));
    }
    ++slot.decisions;
    if (choice > 0) {
      const waypoint::Candidate& c =
          candidates[static_cast<size_t>(i)][static_cast<size_t>(choice - 1)];
      slot.prevHeading = wrapAngle(c.heading);
      slot.prevDistance = c.distance;
    }
  }
}

at::Tensor WaypointAgent::viewLabels(VectorEnv& envs,
                                     std::span<const int> envList) {
  const auto size = world::viewLabelSize();
  const int64_t views = panorama_.num_views;
  at::Tensor out =
      torch::empty({static_cast<int64_t>(envList.size()), views, size});
  std::vector<int64_t> rowOf(slots_.size(), -1);
  for (size_t i = 0; i < envList.size(); ++i)
    rowOf[static_cast<size_t>(envList[i])] = static_cast<int64_t>(i);
  envs.forEach(envList, [&](int env) {
    Slot& slot = *slots_[static_cast<size_t>(env)];
    const sim::Simulator& simulator = envs.simulator(env);
    const sim::Scene& scene = simulator.scene();
    if (slot.labelScene.get() != &scene) {
      // the old renderer goes before the scene it read
      slot.labelRenderer = sim::createRenderer(scene.mesh(), scene.rayTracer(),
                                               simulator.config().renderer);
      slot.labelScene = simulator.scenePtr();
    }
    const std::vector<float> labels = world::viewLabelFeatures(
        *slot.labelRenderer, scene.semantics(), envs.state(env).agent,
        panorama_, static_cast<float>(config_.view_label_min_fraction));
    std::memcpy(out[rowOf[static_cast<size_t>(env)]].data_ptr<float>(),
                labels.data(), labels.size() * sizeof(float));
  });
  return out;
}

WaypointBatch batchDecisions(
    std::span<const std::vector<WaypointDecision>* const> episodes,
    int maxCandidates) {
  VLN_CHECK_ARG(!episodes.empty(), "batchDecisions(): no episodes");
  const auto B = static_cast<int64_t>(episodes.size());
  int64_t T = 0;
  for (const auto* e : episodes) {
    VLN_CHECK_ARG(!e->empty(), "batchDecisions(): an episode has no decisions");
    T = std::max<int64_t>(T, static_cast<int64_t>(e->size()));
  }
  const WaypointDecision& first = episodes.front()->front();
  const int64_t K = maxCandidates;
  WaypointBatch batch;
  auto& in = batch.inputs;
  if (first.rgb.defined())
    in.rgb = torch::zeros({T, B, first.rgb.size(0), first.rgb.size(1)});
  if (first.depth.defined())
    in.depth = torch::zeros({T, B, first.depth.size(0), first.depth.size(1)});
  in.candidates = torch::zeros({T, B, K, 2});
  in.candidate_mask = torch::zeros({T, B, K}, torch::kBool);
  in.prev = torch::zeros({T, B, 2});
  in.not_done = torch::zeros({T, B});
  batch.labels = torch::full({T, B}, -1, torch::kLong);
  batch.acceptable = torch::zeros({T, B, K + 1}, torch::kBool);
  auto polar = in.candidates.accessor<float, 4>();
  auto mask = in.candidate_mask.accessor<bool, 3>();
  auto prev = in.prev.accessor<float, 3>();
  auto notDone = in.not_done.accessor<float, 2>();
  auto labels = batch.labels.accessor<int64_t, 2>();
  auto accepted = batch.acceptable.accessor<bool, 3>();
  for (int64_t b = 0; b < B; ++b) {
    const auto& decisions = *episodes[static_cast<size_t>(b)];
    for (int64_t t = 0; t < static_cast<int64_t>(decisions.size()); ++t) {
      const WaypointDecision& d = decisions[static_cast<size_t>(t)];
      if (in.rgb.defined()) in.rgb[t][b].copy_(d.rgb);
      if (in.depth.defined()) in.depth[t][b].copy_(d.depth);
      VLN_CHECK_ARG(static_cast<int64_t>(d.candidates.size()) <= K,
                    "batchDecisions(): ", d.candidates.size(),
                    " candidates for ", K, " slots");
      for (size_t j = 0; j < d.candidates.size(); ++j) {
        polar[t][b][static_cast<int64_t>(j)][0] = d.candidates[j].heading;
        polar[t][b][static_cast<int64_t>(j)][1] = d.candidates[j].distance;
        mask[t][b][static_cast<int64_t>(j)] = true;
      }
      prev[t][b][0] = d.prev_heading;
      prev[t][b][1] = d.prev_distance;
      notDone[t][b] = t > 0 ? 1.0f : 0.0f;
      labels[t][b] = d.label;
      VLN_CHECK_ARG(d.label >= 0 && d.label <= K &&
                        (K + 1 >= 32 || d.acceptable >> (K + 1) == 0),
                    "batchDecisions(): label ", d.label,
                    " or accepted choices ", d.acceptable, " outside ", K + 1,
                    " choices");
      accepted[t][b][d.label] = true;
      for (int64_t c = 0; c < std::min<int64_t>(K + 1, 32); ++c)
        if ((d.acceptable >> c) & 1u) accepted[t][b][c] = true;
    }
  }
  return batch;
}

at::Tensor mirrorPanoramaViews(const at::Tensor& images) {
  VLN_CHECK_ARG(images.dim() == 5,
                "mirrorPanoramaViews(): images must be "
                "[n, N, h, w, c], got ",
                images.sizes());
  return images.index_select(1, mirroredViewOrder(images.size(1)))
      .flip({3})
      .contiguous();
}

WaypointDecision mirroredDecision(const WaypointDecision& decision) {
  VLN_CHECK_ARG(
      decision.rgb.defined() == decision.rgb_mirrored.defined() &&
          decision.depth.defined() == decision.depth_mirrored.defined(),
      "mirroredDecision(): the decision was collected without its "
      "mirrored panorama (WaypointCollection::mirror)");
  WaypointDecision out = decision;
  out.rgb = decision.rgb_mirrored;
  out.depth = decision.depth_mirrored;
  out.rgb_mirrored = decision.rgb;
  out.depth_mirrored = decision.depth;
  for (waypoint::Candidate& c : out.candidates) {
    c.heading = wrapAngle(-c.heading);
    c.heading_bin =
        (waypoint::kNumHeadings - c.heading_bin) % waypoint::kNumHeadings;
  }
  out.prev_heading = wrapAngle(-decision.prev_heading);
  return out;
}

at::Tensor swapLeftAndRight(const at::Tensor& tokens,
                            const std::vector<bool>& rows, int64_t left,
                            int64_t right) {
  VLN_CHECK_ARG(
      tokens.dim() == 2 && tokens.size(0) == static_cast<int64_t>(rows.size()),
      "swapLeftAndRight(): tokens must be [", rows.size(), ", L], got ",
      tokens.sizes());
  at::Tensor out = tokens.clone();
  for (size_t b = 0; b < rows.size(); ++b) {
    if (!rows[b]) continue;
    const at::Tensor row = tokens[static_cast<int64_t>(b)];
    out[static_cast<int64_t>(b)].masked_fill_(row.eq(left), right);
    out[static_cast<int64_t>(b)].masked_fill_(row.eq(right), left);
  }
  return out;
}

}  // namespace vln::rollout
