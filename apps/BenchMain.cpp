// vlnce-bench: wall-clock timings of the model code on this machine.
//
//   vlnce-bench update --model cma --batch 5 --steps 60 --instr-len 30
//       --threads 2
//     one teacher-forcing update on cached features (RGB [2048,4,4], depth
//     [128,4,4]): forward in sequence mode, inflection-weighted
//     cross-entropy plus progress MSE over the real steps, backward, Adam.
//     Prints the median ms/update after warm-up. The Python/PyTorch peer is
//     scripts/bench_pytorch_update.py with the same flags. --scale cpu
//     takes configs/main.yaml's model instead (small-CNN features RGB
//     [64,4,4] and depth [32,4,4], hidden 128, 151 words, fine-tuned
//     embeddings, no progress monitor), e.g. --batch 16 --steps 90
//     --instr-len 60 for its batches.
//   vlnce-bench act --model cma --batch 8 --threads 2
//     one acting step (step mode, instruction cached) without gradients.
//   vlnce-bench encode --encoder resnet50 --modality rgb --size 224
//       --batch 8 --threads 2
//     one forward of a frozen visual encoder (feature extraction).
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <functional>
#include <numeric>
#include <string>
#include <vector>

#include "common/App.h"
#include "common/Check.h"
#include "models/Loss.h"
#include "models/ObservationEncoder.h"
#include "models/Policy.h"
#include "models/SyntheticBatch.h"

namespace {

using namespace vln;
using namespace vln::models;

struct Timing {
  double median = 0, min = 0, mean = 0;  ///< wall clock, ms
  double cpuMean = 0;  ///< process CPU time (all threads) per run, ms
};

// runs `body` warmup + iters times and summarises the timed iterations (ms)
Timing timeIt(int warmup, int iters, const std::function<void()>& body) {
  for (int i = 0; i < warmup; ++i) body();
  const std::clock_t cpuStart = std::clock();
  std::vector<double> ms;
  for (int i = 0; i < iters; ++i) {
    const auto start = std::chrono::steady_clock::now();
    body();
    ms.push_back(std::chrono::duration<double, std::milli>(
                     std::chrono::steady_clock::now() - start)
                     .count());
  }
  std::vector<double> sorted = ms;
  std::sort(sorted.begin(), sorted.end());
  Timing t;
  const size_t n = sorted.size();
  t.median = n % 2 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
  t.min = sorted.front();
  t.mean = std::accumulate(ms.begin(), ms.end(), 0.0) / static_cast<double>(n);
  t.cpuMean = 1000.0 * static_cast<double>(std::clock() - cpuStart) /
              CLOCKS_PER_SEC / static_cast<double>(n);
  return t;
}

PolicyType parsePolicy(const std::string& name) {
  if (name == "cma") return PolicyType::kCma;
  if (name == "seq2seq") return PolicyType::kSeq2Seq;
  throw std::invalid_argument(
      "--model must be cma or seq2seq, "
      "got '" +
      name + "'");
}

EncoderType parseEncoder(const std::string& name) {
  if (name == "resnet50") return EncoderType::kResNet50;
  if (name == "resnet18") return EncoderType::kResNet18;
  if (name == "small_cnn") return EncoderType::kSmallCnn;
  throw std::invalid_argument(
      "--encoder must be resnet50, resnet18 or small_cnn, got '" + name + "'");
}

// ===========================================================================
// update
// ===========================================================================

struct UpdateArgs {
  std::string model = "cma";
  std::string scale = "paper";
  int batch = 5;
  int steps = 60;
  int instrLen = 30;
};

int runUpdate(const UpdateArgs& a, int threads, int warmup, int iters) {
  ModelConfig config;
  config.policy = parsePolicy(a.model);
  config.progress_monitor = true;
  if (a.scale == "cpu") {
    // configs/main.yaml's model (configs/vln/cpu_base.yaml)
    config.rgb_encoder = EncoderType::kSmallCnn;
    config.depth_encoder = EncoderType::kSmallCnn;
    config.rgb_width = config.rgb_height = 64;
    config.depth_width = config.depth_height = 64;
    config.hidden_size = 128;
    config.vocab_size = 151;
    config.fine_tune_embeddings = true;
    config.progress_monitor = false;
  }
  config.validate();
  torch::manual_seed(0);
  auto policy = makePolicy(config);
  policy->train();
  std::vector<torch::Tensor> trainable;
  for (const auto& p : policy->parameters())
    if (p.requires_grad()) trainable.push_back(p);
  torch::optim::Adam adam(trainable, torch::optim::AdamOptions(2.5e-4));
  const TeacherForcingBatch u =
      syntheticBatch(config, a.batch, a.steps, a.instrLen);

  double lastLoss = 0;
  auto update = [&] {
    // gradients set to none, not zero-filled: backward then writes them
    // instead of adding to zeros
    for (auto& p : trainable) p.mutable_grad().reset();
    const EncodedInstruction instr = policy->encodeInstruction(u.tokens);
    const PolicyOutputs out = policy->forwardSequence(
        instr, u.inputs, policy->initialHidden(a.batch));
    torch::Tensor loss = weightedActionLoss(out.logits, u.actions, u.weights);
    if (config.progress_monitor)
      loss = loss + progressLoss(out.progress, u.progress, u.valid);
    loss.backward();
    adam.step();
    lastLoss = loss.item<double>();
  };
  const Timing t = timeIt(warmup, iters, update);
  std::printf(
      "update %s scale=%s batch=%d steps=%d instr_len=%d threads=%d: median "
      "%.1f ms/update (min %.1f, mean %.1f, CPU %.1f ms/update; %d runs after "
      "%d warm-up; last loss %.4f)\n",
      a.model.c_str(), a.scale.c_str(), a.batch, a.steps, a.instrLen, threads, t.median, t.min,
      t.mean, t.cpuMean, iters, warmup, lastLoss);
  return 0;
}

// ===========================================================================
// act
// ===========================================================================

int runAct(const std::string& model, int batch, int instrLen, int threads,
           int warmup, int iters) {
  ModelConfig config;
  config.policy = parsePolicy(model);
  config.progress_monitor = true;
  torch::manual_seed(0);
  auto policy = makePolicy(config);
  policy->eval();
  torch::InferenceMode inference;
  const torch::Tensor tokens =
      torch::randint(1, config.vocab_size, {batch, instrLen}, torch::kInt64);
  const EncodedInstruction instr = policy->encodeInstruction(tokens);
  const FeatureShape r = rgbFeatureShape(config);
  const FeatureShape d = depthFeatureShape(config);
  PolicyInputs in{torch::relu(torch::randn({batch, r[0], r[1], r[2]})),
                  torch::relu(torch::randn({batch, d[0], d[1], d[2]})),
                  torch::ones({batch}, torch::kInt64), torch::ones({batch})};
  torch::Tensor h = policy->initialHidden(batch);
  const Timing t =
      timeIt(warmup, iters, [&] { h = policy->step(instr, in, h).hidden; });
  std::printf(
      "act %s batch=%d threads=%d: median %.2f ms/step (min %.2f, mean "
      "%.2f)\n",
      model.c_str(), batch, threads, t.median, t.min, t.mean);
  return 0;
}

// ===========================================================================
// encode
// ===========================================================================

int runEncode(const std::string& encoder, const std::string& modality, int size,
              int batch, int threads, int warmup, int iters) {
  VLN_CHECK_ARG(modality == "rgb" || modality == "depth",
                "--modality must be rgb or depth, got '", modality, "'");
  ModelConfig config;
  config.rgb_encoder = config.depth_encoder = parseEncoder(encoder);
  config.rgb_height = config.rgb_width = size;
  config.depth_height = config.depth_width = size;
  config.no_rgb = modality != "rgb";
  config.no_depth = modality != "depth";
  torch::manual_seed(0);
  ObservationEncoder enc(config);
  enc->eval();
  torch::InferenceMode inference;
  const torch::Tensor rgb =
      torch::randint(0, 256, {batch, size, size, 3}, torch::kUInt8);
  const torch::Tensor depth = torch::rand({batch, size, size, 1});
  torch::Tensor out;
  const Timing t = timeIt(warmup, iters, [&] {
    const VisualFeatures f = enc->forward(rgb, depth);
    out = modality == "rgb" ? f.rgb : f.depth;
  });
  std::printf(
      "encode %s %s %dx%d batch=%d threads=%d -> [%s]: median %.1f ms/batch "
      "(%.1f images/s)\n",
      encoder.c_str(), modality.c_str(), size, size, batch, threads,
      [&] {
        std::string s;
        for (int64_t i = 1; i < out.dim(); ++i)
          s += (i > 1 ? "," : "") + std::to_string(out.size(i));
        return s;
      }()
          .c_str(),
      t.median, 1000.0 * batch / t.median);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  vln::common::pinNumericalRuntime("vlnce-bench", argv);
  return vln::common::runMain("vlnce-bench", [&]() -> int {
    CLI::App app{"vlnce-bench: timings of the VLN-CE models"};
    app.require_subcommand(1);
    int threads = 1, warmup = 3, iters = 10;
    auto common = [&](CLI::App* sub) {
      sub->add_option("--threads", threads, "LibTorch intra-op threads")
          ->check(CLI::Range(1, 256));
      sub->add_option("--warmup", warmup, "Untimed iterations first")
          ->check(CLI::Range(0, 1000));
      sub->add_option("--iters", iters, "Timed iterations")
          ->check(CLI::Range(1, 100000));
    };

    UpdateArgs update;
    CLI::App* up = app.add_subcommand("update", "One teacher-forcing update");
    up->add_option("--model", update.model, "cma or seq2seq");
    up->add_option("--scale", update.scale,
                   "paper (VLN-CE's sizes) or cpu (configs/main.yaml's model)")
        ->check(CLI::IsMember({"paper", "cpu"}));
    up->add_option("--batch", update.batch, "Episodes per batch")
        ->check(CLI::Range(1, 4096));
    up->add_option("--steps", update.steps, "Steps of the longest episode")
        ->check(CLI::Range(2, 100000));
    up->add_option("--instr-len", update.instrLen, "Instruction tokens")
        ->check(CLI::Range(2, 10000));
    common(up);

    std::string actModel = "cma";
    int actBatch = 8, actInstr = 30;
    CLI::App* act = app.add_subcommand("act", "One acting step");
    act->add_option("--model", actModel, "cma or seq2seq");
    act->add_option("--batch", actBatch, "Environments")
        ->check(CLI::Range(1, 4096));
    act->add_option("--instr-len", actInstr, "Instruction tokens")
        ->check(CLI::Range(1, 10000));
    common(act);

    std::string encoder = "resnet50", modality = "rgb";
    int size = 224, encBatch = 8;
    CLI::App* enc = app.add_subcommand("encode", "One visual-encoder forward");
    enc->add_option("--encoder", encoder, "resnet50, resnet18 or small_cnn");
    enc->add_option("--modality", modality, "rgb or depth");
    enc->add_option("--size", size, "Square image size (px)")
        ->check(CLI::Range(8, 4096));
    enc->add_option("--batch", encBatch, "Images per batch")
        ->check(CLI::Range(1, 4096));
    common(enc);

    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      return app.exit(e);
    }
    vln::common::setBlasThreadsEnv(threads);
    torch::set_num_threads(threads);
    if (*up) return runUpdate(update, threads, warmup, iters);
    if (*act)
      return runAct(actModel, actBatch, actInstr, threads, warmup, iters);
    return runEncode(encoder, modality, size, encBatch, threads, warmup, iters);
  });
}
