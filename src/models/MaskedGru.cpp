#include "models/MaskedGru.h"

#include <vector>

namespace vln::models {

MaskedGruImpl::MaskedGruImpl(int64_t inputSize, int64_t hiddenSize) {
  gru = register_module(
      "gru", torch::nn::GRU(torch::nn::GRUOptions(inputSize, hiddenSize)));
  torch::NoGradGuard noGrad;
  for (auto& item : gru->named_parameters()) {
    if (item.key().find("weight") != std::string::npos) {
      torch::nn::init::orthogonal_(item.value());
    } else {
      torch::nn::init::zeros_(item.value());
    }
  }
}

std::pair<torch::Tensor, torch::Tensor> MaskedGruImpl::forward(
    const torch::Tensor& x, const torch::Tensor& h0,
    const torch::Tensor& notDone) {
  TORCH_CHECK(x.dim() == 3 && x.size(0) > 0,
              "MaskedGru::forward(): expected x [T > 0, B, I], got ",
              x.sizes());
  const int64_t steps = x.size(0);
  const int64_t batch = x.size(1);
  TORCH_CHECK(h0.dim() == 2 && h0.size(0) == batch,
              "MaskedGru::forward(): expected h0 [", batch, ", H], got ",
              h0.sizes());
  TORCH_CHECK(notDone.dim() == 2 && notDone.size(0) == steps &&
                  notDone.size(1) == batch,
              "MaskedGru::forward(): expected notDone [", steps, ", ", batch,
              "], got ", notDone.sizes());

  // chunk boundaries: t = 0 and every step where any row starts an episode
  const torch::Tensor resets =
      (notDone.slice(0, 1) == 0).any(1).to(torch::kCPU);
  std::vector<int64_t> starts{0};
  const auto flags = resets.accessor<bool, 1>();
  for (int64_t t = 1; t < steps; ++t)
    if (flags[t - 1]) starts.push_back(t);
  starts.push_back(steps);

  const torch::Tensor mask = notDone.to(x.scalar_type()).unsqueeze(-1);
  torch::Tensor h = h0;
  std::vector<torch::Tensor> outputs;
  outputs.reserve(starts.size() - 1);
  for (size_t c = 0; c + 1 < starts.size(); ++c) {
    const int64_t begin = starts[c];
    const int64_t end = starts[c + 1];
    h = h * mask[begin];
    auto [out, hn] = gru->forward(x.slice(0, begin, end), h.unsqueeze(0));
    outputs.push_back(out);
    h = hn.squeeze(0);
  }
  torch::Tensor all =
      outputs.size() == 1 ? outputs.front() : torch::cat(outputs, 0);
  return {all, h};
}

}  // namespace vln::models
