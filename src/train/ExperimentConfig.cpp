#include "train/ExperimentConfig.h"

#include "sim/Agent.h"

namespace vln::train {

void ExperimentConfig::validate() const {
  model.validate();
  // the policy's image sizes are the cameras' sizes: one source of truth
  // would hide mistakes in configs that set only one of them
  VLN_CHECK_ARG(model.rgb_width == sim.rgb.width && model.rgb_height == sim.rgb.height,
                "config: model.rgb_width x model.rgb_height (", model.rgb_width, "x",
                model.rgb_height, ") must equal sim.rgb.width x sim.rgb.height (",
                sim.rgb.width, "x", sim.rgb.height, ")");
  VLN_CHECK_ARG(model.depth_width == sim.depth.camera.width &&
                    model.depth_height == sim.depth.camera.height,
                "config: model.depth_width x model.depth_height (", model.depth_width,
                "x", model.depth_height, ") must equal sim.depth.width x sim.depth.height (",
                sim.depth.camera.width, "x", sim.depth.camera.height, ")");
  // a six-action (RxR) policy's looks would be refused mid-episode by an
  // R2R simulator; a four-action policy on RxR's simulator never looks
  VLN_CHECK_ARG(model.num_actions <= sim::numActions(sim.agent),
                "config: model.num_actions is ", model.num_actions,
                " (LOOK_UP, LOOK_DOWN) but sim.agent.look_actions is false; "
                "the simulator allows ",
                sim::numActions(sim.agent), " actions");
  VLN_CHECK_ARG(sim.depth.min_depth < sim.depth.max_depth,
                "config: sim.depth.min_depth (", sim.depth.min_depth,
                ") must be below sim.depth.max_depth (", sim.depth.max_depth, ")");
  VLN_CHECK_ARG(pretrain.min_goal_distance < pretrain.max_goal_distance,
                "config: pretrain.min_goal_distance must be below pretrain.max_goal_distance");
  VLN_CHECK_ARG(!(trainer.fine_tune_dagger && trainer.init_checkpoint.empty()),
                "config: trainer.fine_tune_dagger (DA*) needs trainer.init_checkpoint");
  VLN_CHECK_ARG(!(trainer.fine_tune_dagger && trainer.dagger_iterations == 0),
                "config: trainer.fine_tune_dagger needs trainer.dagger_iterations > 0");
  // the swapped instruction must be one
  VLN_CHECK_ARG(trainer.instruction_contrast_weight == 0.0 ||
                    model.usesInstruction(),
                "config: trainer.instruction_contrast_weight needs the "
                "instruction (model.no_instruction is true)");
  // the recollect trainer's keys mean nothing to the store's trainer, and
  // it trains by teacher forcing only (VLN-CE's recollect_trainer)
  const bool recollect = trainer.mode == "recollect";
  VLN_CHECK_ARG(recollect || (trainer.effective_batch_size == -1 &&
                              trainer.max_traj_len == -1),
                "config: trainer.effective_batch_size and trainer.max_traj_len "
                "apply to trainer.mode recollect only (mode is '",
                trainer.mode, "')");
  VLN_CHECK_ARG(!recollect || trainer.dagger_iterations == 0,
                "config: trainer.mode recollect trains by teacher forcing on "
                "the ground truth; trainer.dagger_iterations must be 0 (use "
                "mode dagger for DAgger)");
  // the recollect trainer has no rounds or epochs of a store to anneal over
  VLN_CHECK_ARG(!recollect || trainer.lr_schedule == "constant",
                "config: trainer.lr_schedule '", trainer.lr_schedule,
                "' needs trainer.mode dagger; mode recollect trains at the "
                "constant trainer.lr");
  VLN_CHECK_ARG(trainer.effective_batch_size == -1 ||
                    (trainer.effective_batch_size > 0 &&
                     trainer.effective_batch_size % trainer.batch_size == 0),
                "config: trainer.effective_batch_size (",
                trainer.effective_batch_size,
                ") must be -1 or a positive multiple of trainer.batch_size (",
                trainer.batch_size, ")");
  VLN_CHECK_ARG(trainer.max_traj_len == -1 || trainer.max_traj_len >= 1,
                "config: trainer.max_traj_len must be -1 (off) or at least 1, "
                "got ",
                trainer.max_traj_len);
  VLN_CHECK_ARG(!recollect || trainer.preload_size >= trainer.batch_size,
                "config: trainer.preload_size (", trainer.preload_size,
                ") must be at least trainer.batch_size (", trainer.batch_size,
                ")");
  // RxR runs: the filter names what is read; text features need RxR's
  // instruction ids, which R2R episode files do not have
  if (dataset.isRxr()) {
    try {
      dataset.rxr_filter.validate();
    } catch (const std::invalid_argument& error) {
      throw std::invalid_argument(std::string("config: dataset.rxr_filter: ") +
                                  error.what());
    }
  }
  VLN_CHECK_ARG(!model.usesTextFeatures() || dataset.isRxr(),
                "config: model.instruction_features is rxr_text, which reads "
                "RxR's text feature files by instruction_id, but "
                "dataset.format is '", dataset.format, "' (set rxr)");
  bool selectionEvaluated = false;
  for (const auto& split : eval.splits) selectionEvaluated |= split == eval.selection_split;
  VLN_CHECK_ARG(selectionEvaluated, "config: eval.selection_split '", eval.selection_split,
                "' is not among eval.splits");
}

ExperimentConfig loadExperimentConfig(const std::filesystem::path& file,
                                      const std::vector<std::string>& overrides) {
  ExperimentConfig config;
  common::readConfigFile(file, overrides,
                         [&](common::ConfigVisitor& v) { config.visit(v); });
  try {
    config.validate();
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(file.string() + ": " + error.what());
  }
  return config;
}

std::string experimentConfigYaml(const ExperimentConfig& config) {
  return common::configToYaml(config);
}

}  // namespace vln::train
