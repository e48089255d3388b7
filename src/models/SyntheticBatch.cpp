#include "models/SyntheticBatch.h"

#include <torch/torch.h>

#include <ATen/CPUGeneratorImpl.h>

#include "common/Check.h"
#include "models/Loss.h"

namespace vln::models {

TeacherForcingBatch syntheticBatch(const ModelConfig& config, int64_t batch,
                                   int64_t steps, int64_t instrLen,
                                   uint64_t seed) {
  VLN_CHECK_ARG(batch >= 1 && steps >= 2 && instrLen >= 2,
                "syntheticBatch(): need batch >= 1, steps >= 2, instr_len >= "
                "2, got ",
                batch, ", ", steps, ", ", instrLen);
  auto gen = at::make_generator<at::CPUGeneratorImpl>(seed);
  const int64_t T = steps, B = batch;
  TeacherForcingBatch u;

  // episode lengths in [T/2, T] and instruction lengths in [L/2, L]; row 0
  // is the longest of both so the padded sizes are exactly T and L
  torch::Tensor lengths = torch::randint(T / 2, T + 1, {B}, gen);
  lengths[0] = T;
  u.tokens = torch::zeros({B, instrLen}, torch::kInt64);
  for (int64_t b = 0; b < B; ++b) {
    const int64_t words =
        b == 0 ? instrLen
               : torch::randint(instrLen / 2, instrLen + 1, {1}, gen)
                     .item<int64_t>();
    u.tokens[b].slice(0, 0, words).random_(1, config.vocab_size, gen);
  }

  if (config.usesRgb()) {
    const FeatureShape r = rgbFeatureShape(config);
    u.inputs.rgb = torch::relu(torch::randn({T, B, r[0], r[1], r[2]}, gen));
  }
  if (config.usesDepth()) {
    const FeatureShape d = depthFeatureShape(config);
    u.inputs.depth = torch::relu(torch::randn({T, B, d[0], d[1], d[2]}, gen));
  }

  // MOVE_FORWARD 70%, TURN_LEFT 15%, TURN_RIGHT 15%, STOP on the last step
  const torch::Tensor draw = torch::rand({T, B}, gen);
  u.actions = torch::where(
      draw < 0.7, torch::ones({T, B}, torch::kInt64),
      torch::where(draw < 0.85, torch::full({T, B}, 2, torch::kInt64),
                   torch::full({T, B}, 3, torch::kInt64)));
  const torch::Tensor t = torch::arange(T).unsqueeze(1).expand({T, B});
  u.valid = t < lengths.unsqueeze(0);
  u.actions = torch::where(t == lengths.unsqueeze(0) - 1,
                           torch::zeros_like(u.actions), u.actions);
  u.inputs.prev_actions = torch::cat(
      {torch::zeros({1, B}, torch::kInt64), u.actions.slice(0, 0, T - 1)});
  u.inputs.not_done = torch::ones({T, B});
  u.inputs.not_done[0].zero_();
  u.weights = inflectionWeights(u.actions, u.valid, /*coef=*/3.2);
  u.progress = (t.to(torch::kFloat32) + 1) / lengths.unsqueeze(0);
  return u;
}

}  // namespace vln::models
