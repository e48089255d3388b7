// Components of a teacher-forcing update at paper scale (batch 5, 60 steps,
// 30-token instructions, cached ResNet features), so a regression can be
// located: forward only, forward + backward, and the full update with Adam;
// plus one acting step. Single-threaded unless VLN_BENCH_THREADS is set.
// The end-to-end number is `vlnce-bench update` (docs/performance.md).
#include <benchmark/benchmark.h>

#include <cstdlib>

#include "models/Loss.h"
#include "models/Policy.h"
#include "models/SyntheticBatch.h"

namespace vln::models {
namespace {

constexpr int64_t kBatch = 5, kSteps = 60, kInstrLen = 30;

struct Setup {
  explicit Setup(PolicyType type) {
    if (const char* threads = std::getenv("VLN_BENCH_THREADS"))
      torch::set_num_threads(std::atoi(threads));
    else
      torch::set_num_threads(1);
    config.policy = type;
    config.progress_monitor = true;
    torch::manual_seed(0);
    policy = makePolicy(config);
    batch = syntheticBatch(config, kBatch, kSteps, kInstrLen);
  }
  torch::Tensor loss() {
    const PolicyOutputs out =
        policy->forwardSequence(policy->encodeInstruction(batch.tokens),
                                batch.inputs, policy->initialHidden(kBatch));
    return weightedActionLoss(out.logits, batch.actions, batch.weights) +
           progressLoss(out.progress, batch.progress, batch.valid);
  }
  ModelConfig config;
  std::shared_ptr<PolicyImpl> policy;
  TeacherForcingBatch batch;
};

void forwardOnly(benchmark::State& state, PolicyType type) {
  Setup s(type);
  torch::NoGradGuard noGrad;
  for (auto _ : state) benchmark::DoNotOptimize(s.loss().item<float>());
}

void forwardBackward(benchmark::State& state, PolicyType type) {
  Setup s(type);
  for (auto _ : state) {
    s.policy->zero_grad();
    s.loss().backward();
  }
}

void fullUpdate(benchmark::State& state, PolicyType type) {
  Setup s(type);
  std::vector<torch::Tensor> trainable;
  for (const auto& p : s.policy->parameters())
    if (p.requires_grad()) trainable.push_back(p);
  torch::optim::Adam adam(trainable, torch::optim::AdamOptions(2.5e-4));
  for (auto _ : state) {
    // gradients set to none, not zero-filled: backward then writes them
    // instead of adding to zeros
    for (auto& p : trainable) p.mutable_grad().reset();
    s.loss().backward();
    adam.step();
  }
}

void actStep(benchmark::State& state, PolicyType type) {
  Setup s(type);
  s.policy->eval();
  torch::InferenceMode inference;
  const int64_t envs = state.range(0);
  const TeacherForcingBatch b =
      syntheticBatch(s.config, envs, /*steps=*/2, kInstrLen);
  const EncodedInstruction instr = s.policy->encodeInstruction(b.tokens);
  const PolicyInputs in{b.inputs.rgb[1], b.inputs.depth[1],
                        b.inputs.prev_actions[1], b.inputs.not_done[1]};
  torch::Tensor h = s.policy->initialHidden(envs);
  for (auto _ : state) h = s.policy->step(instr, in, h).hidden;
}

BENCHMARK_CAPTURE(forwardOnly, cma, PolicyType::kCma)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(forwardBackward, cma, PolicyType::kCma)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(fullUpdate, cma, PolicyType::kCma)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(fullUpdate, seq2seq, PolicyType::kSeq2Seq)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(actStep, cma, PolicyType::kCma)
    ->Arg(1)
    ->Arg(8)
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace vln::models
