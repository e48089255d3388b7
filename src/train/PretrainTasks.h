#pragma once
// Encoder pretraining: the frozen encoders of the paper (Section 4: an
// ImageNet ResNet-50 for RGB, DD-PPO's point-goal ResNet-50 for depth)
// cannot be downloaded here, so the project trains its own in its own
// simulator, on procedural houses kept apart from the VLN houses:
//  - trainer.task = depth_pointnav: point-goal navigation from depth
//    (PointNavPretrainer.h), the stand-in for DD-PPO;
//  - trainer.task = rgb_semantic: recognising the object categories, their
//    colours and the room type in a view (SemanticPretrainer.h), the
//    stand-in for ImageNet.
// (trainer.task = waypoint_predictor trains the candidate-waypoint
// predictor on the world's nav-graphs instead: WaypointPretrainer.h.)
// Both write, in the run directory: metrics.jsonl (and tb/ when
// output.tensorboard), pretrain_metrics.json (held-out results of the
// trained encoder and of a reference that has no learned vision), and the
// trained CNN as a tensor file (models::saveModule of the encoder's
// cnnModule()) that model.depth_weights / model.rgb_weights load strictly
// (models::ObservationEncoder::loadPretrained()).
//
// Houses: pretrain.house_seed + i with pretrain.house (world::HouseConfig);
// i < pretrain.train_houses are the training houses, the next
// pretrain.heldout_houses the held-out ones. Navmeshes use sim.navmesh.
//
// Determinism: everything random derives from trainer.seed; with the same
// trainer.torch_threads and trainer.num_envs a run is repeatable (renders
// do not depend on trainer.env_threads).

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "sim/Scene.h"
#include "train/ExperimentConfig.h"

namespace vln::train {

/// The generated pretraining houses as scenes (navmesh built, semantics
/// attached); train[i] is house pretrain.house_seed + i, heldout[j] is
/// house pretrain.house_seed + train_houses + j.
struct PretrainHouses {
  std::vector<std::shared_ptr<const sim::Scene>> train;
  std::vector<std::shared_ptr<const sim::Scene>> heldout;
};

/// Generates every pretraining house of `config` on `threads` threads
/// (bit-identical for any thread count). Throws std::invalid_argument naming
/// the house seed when a house cannot be generated or has no navmesh.
PretrainHouses generatePretrainHouses(const ExperimentConfig& config,
                                      int threads);

/// Checks the settings the pretraining task trainer.task reads that the
/// YAML bounds cannot (cross-field rules, sensor sizes equal to the model's,
/// the encoder being trainable input, ...). Throws std::invalid_argument
/// naming the key and its value.
void validatePretrainConfig(const ExperimentConfig& config);

/// Where the trained encoder goes: pretrain.encoder_out, or
/// <runDir>/<defaultName> when that is empty.
std::filesystem::path encoderOutputPath(const ExperimentConfig& config,
                                        const std::filesystem::path& runDir,
                                        const std::string& defaultName);

/// trainer.task = depth_pointnav: DAgger imitation of the geodesic follower
/// on point-goal episodes from depth, held-out success/SPL against a
/// no-depth control, a random agent and the follower itself; writes
/// <runDir>/pretrain_metrics.json and the depth CNN to encoderOutputPath(
/// config, runDir, "depth_encoder.pt"). Expects logging set up; sets
/// LibTorch's thread count and seed itself.
void runDepthPointNavPretraining(const ExperimentConfig& config,
                                 const std::filesystem::path& runDir);

/// trainer.task = rgb_semantic: multi-label object categories and colours
/// in view plus the room type, from RGB; held-out room accuracy, mean
/// average precision and F1 against the label-prior predictor; writes
/// <runDir>/pretrain_metrics.json and the RGB CNN to encoderOutputPath(
/// config, runDir, "rgb_encoder.pt").
void runRgbSemanticPretraining(const ExperimentConfig& config,
                               const std::filesystem::path& runDir);

}  // namespace vln::train
