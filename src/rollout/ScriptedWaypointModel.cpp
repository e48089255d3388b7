#include "rollout/ScriptedWaypointModel.h"

#include <torch/torch.h>

#include "common/Check.h"
#include "rollout/ExportedArchive.h"
#include "rollout/ObservationBatch.h"
#include "world/ViewLabels.h"

namespace vln::rollout {

namespace {

constexpr const char* kWho = "ScriptedWaypointModel";

}  // namespace

ScriptedWaypointModel::ScriptedWaypointModel(const std::filesystem::path& file,
                                             int maxInstructionLength,
                                             const std::string& device)
    : ScriptedWaypointModel(loadExportedArchive(file, device, kWho), file,
                            maxInstructionLength, parseDevice(device, kWho)) {}

ScriptedWaypointModel::ScriptedWaypointModel(torch::jit::Module module,
                                             const std::filesystem::path& file,
                                             int maxInstructionLength,
                                             torch::Device device)
    : file_(file),
      module_(std::move(module)),
      device_(device),
      maxInstructionLength_(maxInstructionLength) {
  VLN_CHECK_ARG(maxInstructionLength >= 1, kWho,
                ": dataset.max_instruction_length must be >= 1, got ",
                maxInstructionLength);
  config_ = exportedModelConfig(module_, file);
  VLN_CHECK_ARG(isWaypointExport(module_), kWho, ": '", file.string(),
                "' is not a waypoint policy export (no num_views attribute); "
                "a low-level policy's export runs as ScriptedPolicyAgent");
  const c10::IValue views = module_.attr("num_views");
  VLN_CHECK_ARG(views.isInt() && views.toInt() >= 1, kWho, ": '", file.string(),
                "': attribute num_views is not a positive int");
  numViews_ = static_cast<int>(views.toInt());
  hasPredictor_ = module_.hasattr("has_predictor") &&
                  module_.attr("has_predictor").isBool() &&
                  module_.attr("has_predictor").toBool();
  checkRunsOnObservations(module_, config_, file, kWho);
  // the goal labels step() passes are world::goalLabels()' layout
  VLN_CHECK_ARG(!config_.goal_match ||
                    config_.rgb_semantic_outputs == world::viewLabelSize(),
                kWho, ": '", file.string(),
                "' matches the goal over model.rgb_semantic_outputs ",
                config_.rgb_semantic_outputs,
                " labels; the instruction's goal labels are ",
                world::viewLabelSize());
  // the methods step() and propose() call
  std::vector<const char*> methods = {"step_features"};
  if (hasPredictor_)
    methods.insert(methods.end(), {"heatmap_features", "suppress"});
  for (const char* method : methods)
    VLN_CHECK_ARG(module_.find_method(method).has_value(), kWho, ": '",
                  file.string(), "' has no method ", method,
                  " (not written by models::exportWaypointPolicy?)");
}

ScriptedWaypointModel::~ScriptedWaypointModel() = default;

ScriptedWaypointModel::EnvState& ScriptedWaypointModel::state(int env) {
  VLN_CHECK_ARG(env >= 0, kWho, ": environment ", env, " out of range");
  if (states_.size() <= static_cast<size_t>(env))
    states_.resize(static_cast<size_t>(env) + 1);
  return states_[static_cast<size_t>(env)];
}

void ScriptedWaypointModel::reset(int env, const data::Episode& episode) {
  EnvState& s = state(env);
  s.tokens = archiveTokens(episode, config_, maxInstructionLength_, kWho);
  if (config_.goal_match) {
    const data::Episode* one[] = {&episode};
    s.goalLabels = batchGoalLabels(one)[0];
  }
  s.hidden = torch::zeros({2, config_.hidden_size},
                          torch::TensorOptions(device_).dtype(torch::kFloat32));
  s.started = true;
}

at::Tensor ScriptedWaypointModel::orPlaceholder(const at::Tensor& features,
                                                int64_t n) const {
  return features.defined() ? features
                            : torch::zeros({n}, torch::TensorOptions(device_));
}

PanoramaFeatures ScriptedWaypointModel::encode(const at::Tensor& rgb,
                                               const at::Tensor& depth) {
  torch::NoGradGuard noGrad;
  PanoramaFeatures out;
  auto run = [&](const char* method, const at::Tensor& views) {
    const int64_t n = views.size(0);
    return module_.run_method(method, views.to(device_).flatten(0, 1))
        .toTensor()
        .reshape({n, views.size(1), -1});
  };
  if (config_.usesRgb()) {
    VLN_CHECK_ARG(rgb.defined(), kWho, "::encode(): no RGB views");
    out.rgb = run("encode_rgb", rgb);
  }
  if (config_.usesDepth()) {
    VLN_CHECK_ARG(depth.defined(), kWho, "::encode(): no depth views");
    out.depth = run("encode_depth", depth);
  }
  return out;
}

std::vector<std::vector<waypoint::Candidate>> ScriptedWaypointModel::propose(
    const PanoramaFeatures& features) {
  VLN_CHECK_ARG(hasPredictor_, kWho, ": '", file_.string(),
                "' was exported without the predictor (has_predictor is "
                "false): it cannot propose candidates");
  torch::NoGradGuard noGrad;
  const int64_t n =
      (features.rgb.defined() ? features.rgb : features.depth).size(0);
  // the heatmap, then the archive's suppression of it: each candidate's
  // cell gives its bins and score, as waypoint::heatmapNms() reports them
  const at::Tensor heatmap =
      module_
          .run_method("heatmap_features", orPlaceholder(features.rgb, n),
                      orPlaceholder(features.depth, n))
          .toTensor();
  const auto proposed = module_.run_method("suppress", heatmap).toTuple();
  const at::Tensor polar = proposed->elements()[0]
                               .toTensor()
                               .to(torch::kCPU, torch::kFloat32)
                               .contiguous();
  const at::Tensor mask = proposed->elements()[1]
                              .toTensor()
                              .to(torch::kCPU, torch::kBool)
                              .contiguous();
  const at::Tensor cells =
      heatmap.to(torch::kCPU, torch::kFloat32).contiguous();
  VLN_CHECK_ARG(polar.dim() == 3 && polar.size(0) == n && polar.size(2) == 2 &&
                    mask.dim() == 2 && mask.size(0) == n &&
                    mask.size(1) == polar.size(1) && cells.dim() == 3 &&
                    cells.size(0) == n &&
                    cells.size(1) == waypoint::kNumHeadings &&
                    cells.size(2) == waypoint::kNumDistances,
                kWho, ": '", file_.string(),
                "' proposed candidates of unexpected shapes ", polar.sizes(),
                ", ", mask.sizes(), " (heatmap ", cells.sizes(), ")");
  const auto polarAt = polar.accessor<float, 3>();
  const auto maskAt = mask.accessor<bool, 2>();
  const auto cellAt = cells.accessor<float, 3>();
  std::vector<std::vector<waypoint::Candidate>> out(static_cast<size_t>(n));
  for (int64_t i = 0; i < n; ++i)
    for (int64_t j = 0; j < mask.size(1); ++j) {
      if (!maskAt[i][j]) continue;
      const float heading = polarAt[i][j][0], distance = polarAt[i][j][1];
      const int h = waypoint::headingBin(heading);
      const int d = waypoint::distanceBin(distance);
      VLN_CHECK_ARG(d >= 0, kWho, ": '", file_.string(),
                    "' proposed a candidate at ", distance,
                    " m, off the heatmap's distance bins");
      out[static_cast<size_t>(i)].push_back(
          waypoint::candidateAt(h, d, cellAt[i][h][d]));
    }
  return out;
}

at::Tensor ScriptedWaypointModel::step(std::span<const int> envs,
                                       const PanoramaFeatures& features,
                                       const at::Tensor& candidates,
                                       const at::Tensor& mask,
                                       const at::Tensor& prev,
                                       const at::Tensor& notDone,
                                       const at::Tensor& textMask) {
  // an archive's step reads every word (leg_words_only refuses export)
  VLN_CHECK_ARG(!textMask.defined(), kWho,
                "::step(): an exported policy reads the whole instruction; "
                "waypoint_agent.leg_words_only needs a checkpoint");
  torch::NoGradGuard noGrad;
  const auto n = static_cast<int64_t>(envs.size());
  std::vector<const std::vector<int64_t>*> rows;
  std::vector<at::Tensor> goalLabels, hiddens;
  for (int env : envs) {
    const EnvState& s = state(env);
    VLN_CHECK_ARG(s.started, kWho, "::step(): environment ", env,
                  " was never reset");
    rows.push_back(&s.tokens);
    goalLabels.push_back(s.goalLabels);
    hiddens.push_back(s.hidden);
  }
  // with model.goal_match the goal labels follow the instruction
  // (models/WaypointExport.h)
  std::vector<c10::IValue> arguments = {orPlaceholder(features.rgb, n),
                                        orPlaceholder(features.depth, n),
                                        tokenBatch(rows, config_).to(device_)};
  if (config_.goal_match)
    arguments.emplace_back(torch::stack(goalLabels, 0).to(device_));
  for (const at::Tensor& t :
       {candidates.to(device_), mask.to(device_), prev.to(device_),
        notDone.to(device_), torch::stack(hiddens, 0)})
    arguments.emplace_back(t);
  const auto output =
      module_.get_method("step_features")(std::move(arguments)).toTuple();
  VLN_CHECK_ARG(output->elements().size() == 2, kWho, ": '", file_.string(),
                "' step_features returned ", output->elements().size(),
                " values, expected 2");
  const at::Tensor logits = output->elements()[0]
                                .toTensor()
                                .to(torch::kCPU, torch::kFloat64)
                                .contiguous();
  const at::Tensor hidden = output->elements()[1].toTensor();
  VLN_CHECK_ARG(logits.dim() == 2 && logits.size(0) == n &&
                    logits.size(1) == candidates.size(1) + 1,
                kWho, ": '", file_.string(), "' step_features returned logits ",
                logits.sizes(), ", expected [", n, ", ", candidates.size(1) + 1,
                "]");
  for (int64_t i = 0; i < n; ++i)
    state(envs[static_cast<size_t>(i)]).hidden = hidden[i].clone();
  return logits;
}

}  // namespace vln::rollout
