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

namespace vln::rollout {

struct WaypointAgent::Slot {
  const data::Episode* episode = nullptr;
  models::EncodedInstruction instruction;
  torch::Tensor hidden;  // [1, 2, H]
  std::vector<sim::Action> queue;
  size_t next = 0;
  sim::AgentState teleport;  // the target of a queued kTeleport
  int decisions = 0;
  float prevHeading = 0.0f;
  float prevDistance = 0.0f;
  int referenceIndex = 1;  // oracle: reference_path's next waypoint
  std::vector<WaypointDecision> record;
  std::vector<WaypointChoice> choices;
  EpisodeDraws draws;
  sim::Panorama panorama;
};

WaypointAgent::WaypointAgent(
    std::shared_ptr<models::WaypointCmaPolicyImpl> policy,
    models::ObservationEncoder encoder, models::WaypointPredictor predictor,
    CandidateNms nms, const WaypointAgentConfig& config,
    const sim::PanoramaConfig& panorama, const sim::AgentConfig& agent,
    int numEnvs, bool sampleActions, uint64_t seed, int maxInstructionLength)
    : policy_(std::move(policy)),
      encoder_(std::move(encoder)),
      predictor_(std::move(predictor)),
      nms_(nms),
      config_(config),
      panorama_(panorama),
      agent_(agent),
      sample_(sampleActions),
      seed_(seed),
      maxInstructionLength_(maxInstructionLength) {
  VLN_CHECK_ARG(numEnvs >= 1, "WaypointAgent: numEnvs must be >= 1");
  VLN_CHECK_ARG(config.candidates != "predictor" || !predictor_.is_empty(),
                "WaypointAgent: waypoint_agent.candidates is predictor but no "
                "predictor was given");
  for (int i = 0; i < numEnvs; ++i) slots_.push_back(std::make_unique<Slot>());
}

WaypointAgent::~WaypointAgent() = default;

void WaypointAgent::collect(const WaypointCollection& collection) {
  collecting_ = true;
  collection_ = collection;
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
  torch::NoGradGuard noGrad;
  policy_->eval();
  const data::Episode* one[] = {&episode};
  const torch::Device device = policy_->view_linear->weight.device();
  slot.instruction = policy_->encodeInstruction(
      batchInstructions(one, maxInstructionLength_).to(device));
  slot.hidden = policy_->initialHidden(1);
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
  policy_->eval();
  const torch::Device device = policy_->view_linear->weight.device();
  const int64_t views = panorama_.num_views;
  const models::ModelConfig& model = policy_->config();
  torch::Tensor rgb, depth;
  if (model.usesRgb()) {
    const int64_t h = panorama_.rgb.height, w = panorama_.rgb.width;
    rgb = torch::empty({n, views, h, w, 3}, torch::kUInt8);
    for (int64_t i = 0; i < n; ++i) {
      const auto& p = slots_[static_cast<size_t>(envList[i])]->panorama;
      std::memcpy(rgb[i].data_ptr(), p.rgb.data(), p.rgb.size());
    }
    rgb = rgb.to(device);
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
    depth = depth.to(device);
  }
  encoder_->eval();
  const models::VisualFeatures features = encoder_->forward(rgb, depth);
  const torch::Tensor rgbFeatures = features.rgb.defined()
                                        ? features.rgb.reshape({n, views, -1})
                                        : torch::Tensor();
  const torch::Tensor depthFeatures =
      features.depth.defined() ? features.depth.reshape({n, views, -1})
                               : torch::Tensor();

  // candidates
  std::vector<std::vector<waypoint::Candidate>> candidates(
      static_cast<size_t>(n));
  if (config_.candidates == "predictor") {
    predictor_->eval();
    const torch::Tensor probabilities =
        models::waypointProbabilities(
            predictor_->forward(depthFeatures, rgbFeatures))
            .to(torch::kCPU)
            .contiguous();
    for (int64_t i = 0; i < n; ++i) {
      const float* row = probabilities[i].data_ptr<float>();
      candidates[static_cast<size_t>(i)] = waypoint::heatmapNms(
          std::span<const float>(row, waypoint::kHeatmapSize),
          nms_.max_candidates, nms_.heading_radius, nms_.distance_radius,
          nms_.min_score);
    }
  } else {
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
  std::vector<const models::EncodedInstruction*> instructions;
  std::vector<torch::Tensor> hiddens;
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
    instructions.push_back(&slot.instruction);
    hiddens.push_back(slot.hidden);
  }
  models::WaypointPolicyInputs inputs{rgbFeatures,      depthFeatures,
                                      polar.to(device), mask.to(device),
                                      prev.to(device),  notDone.to(device)};
  const models::EncodedInstruction instruction =
      model.usesInstruction() ? stackInstructions(instructions)
                              : models::EncodedInstruction{};
  const models::WaypointPolicyOutputs out =
      policy_->step(instruction, inputs, torch::cat(hiddens, 0));
  const torch::Tensor logits =
      out.logits.to(torch::kCPU, torch::kFloat64).contiguous();

  // choices (and the oracle's labels), per environment in parallel: the
  // approaches and the oracle plan on the navmesh
  std::vector<int> taken(static_cast<size_t>(n)),
      labels(static_cast<size_t>(n));
  for (int64_t i = 0; i < n; ++i) {
    Slot& slot = *slots_[static_cast<size_t>(envList[i])];
    slot.hidden = out.hidden.slice(0, i, i + 1).clone();
  }
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
      int choice = waypoint::oracleChoice(navmesh, agent_, state, cands, target,
                                          rule, config_.execution);
      if (choice < 0 && !final && !cands.empty()) {
        // at an intermediate waypoint with nothing closer: head for the goal
        choice = waypoint::oracleChoice(navmesh, agent_, state, cands,
                                        slot.episode->goals.front().position,
                                        config_.approach, config_.execution);
      }
      label = choice + 1;
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
      WaypointDecision d;
      if (rgbFeatures.defined())
        d.rgb = rgbFeatures[i].to(torch::kCPU, torch::kHalf).clone();
      if (depthFeatures.defined())
        d.depth = depthFeatures[i].to(torch::kCPU, torch::kHalf).clone();
      d.candidates = candidates[static_cast<size_t>(i)];
      d.prev_heading = slot.prevHeading;
      d.prev_distance = slot.prevDistance;
      d.label = labels[static_cast<size_t>(i)];
      d.taken = choice;
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
  auto polar = in.candidates.accessor<float, 4>();
  auto mask = in.candidate_mask.accessor<bool, 3>();
  auto prev = in.prev.accessor<float, 3>();
  auto notDone = in.not_done.accessor<float, 2>();
  auto labels = batch.labels.accessor<int64_t, 2>();
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
    }
  }
  return batch;
}

}  // namespace vln::rollout
