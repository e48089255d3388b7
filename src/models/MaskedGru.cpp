#include "models/MaskedGru.h"

#include <vector>

namespace vln::models {
namespace {

using torch::Tensor;
using torch::autograd::AutogradContext;
using torch::autograd::tensor_list;

// The recurrence of a GRU over precomputed input gates, as one autograd node.
// Autograd through a step-by-step GRU records each step's weight gradient
// as a separate [3H, H] product and sums them one by one (memory bound, and
// most of an update's time at paper scale); here the backward loop carries
// only the state gradient and both weight gradients are one matrix product
// over all T*B steps at the end. Gate order and formulas are PyTorch's:
//   r = s(gi_r + gh_r), z = s(gi_z + gh_z), n = tanh(gi_n + r * gh_n),
//   h' = (1 - z) * n + z * h,  gh = W_hh h + b_hh,
// with h replaced by h * not_done[t] before step t.
struct GruRecurrence : public torch::autograd::Function<GruRecurrence> {
  // gi [T, B, 3H] (input gates incl. b_ih), h0 [B, H], whh [3H, H],
  // bhh [3H], notDone [T, B] -> outputs [T, B, H]
  static Tensor forward(AutogradContext* ctx, const Tensor& gi,
                        const Tensor& h0, const Tensor& whh, const Tensor& bhh,
                        const Tensor& notDone) {
    const int64_t steps = gi.size(0), batch = gi.size(1), hidden = h0.size(1);
    const auto opts = h0.options();
    Tensor out = torch::empty({steps, batch, hidden}, opts);
    Tensor rz = torch::empty({steps, batch, 2 * hidden}, opts);
    Tensor n = torch::empty({steps, batch, hidden}, opts);
    Tensor ghn = torch::empty({steps, batch, hidden}, opts);
    Tensor hprev = torch::empty({steps, batch, hidden}, opts);
    const Tensor mask = notDone.unsqueeze(-1);
    const Tensor whhT = whh.t();
    const Tensor giC = gi.contiguous();
    Tensor h = h0;
    for (int64_t t = 0; t < steps; ++t) {
      Tensor hp = hprev[t];
      torch::mul_out(hp, h, mask[t]);
      const Tensor gh = torch::addmm(bhh, hp, whhT);  // [B, 3H]
      const Tensor git = giC[t];
      Tensor rzt = rz[t];
      torch::add_out(rzt, git.narrow(1, 0, 2 * hidden),
                     gh.narrow(1, 0, 2 * hidden));
      rzt.sigmoid_();
      Tensor ghnt = ghn[t];
      ghnt.copy_(gh.narrow(1, 2 * hidden, hidden));
      Tensor nt = n[t];
      torch::addcmul_out(nt, git.narrow(1, 2 * hidden, hidden),
                         rzt.narrow(1, 0, hidden), ghnt);
      nt.tanh_();
      // h' = n + z * (h - n)
      Tensor ht = out[t];
      torch::sub_out(ht, hp, nt);
      ht.mul_(rzt.narrow(1, hidden, hidden)).add_(nt);
      h = ht;
    }
    // intermediates hold no graph, so they travel as plain saved data
    ctx->save_for_backward({whh, notDone});
    ctx->saved_data["rz"] = rz;
    ctx->saved_data["n"] = n;
    ctx->saved_data["ghn"] = ghn;
    ctx->saved_data["hprev"] = hprev;
    return out;
  }

  static tensor_list backward(AutogradContext* ctx, tensor_list grads) {
    const auto saved = ctx->get_saved_variables();
    const Tensor& whh = saved[0];
    const Tensor mask = saved[1].unsqueeze(-1);
    const Tensor rz = ctx->saved_data["rz"].toTensor();
    const Tensor n = ctx->saved_data["n"].toTensor();
    const Tensor ghn = ctx->saved_data["ghn"].toTensor();
    const Tensor hprev = ctx->saved_data["hprev"].toTensor();
    const Tensor& dout = grads[0];
    const int64_t steps = n.size(0), batch = n.size(1), hidden = n.size(2);

    Tensor dgi = torch::empty({steps, batch, 3 * hidden}, n.options());
    Tensor dgh = torch::empty({steps, batch, 3 * hidden}, n.options());
    Tensor dh = torch::zeros({batch, hidden}, n.options());
    for (int64_t t = steps - 1; t >= 0; --t) {
      if (dout.defined()) dh = dh + dout[t];
      const Tensor r = rz[t].narrow(1, 0, hidden);
      const Tensor z = rz[t].narrow(1, hidden, hidden);
      const Tensor& nt = n[t];
      // through h' = (1 - z) n + z h
      const Tensor dn = dh - dh * z;
      const Tensor dz = dh * (hprev[t] - nt);
      // through the activations
      const Tensor dnPre = dn - dn * nt * nt;
      const Tensor drPre = dnPre * ghn[t] * r * (1 - r);
      const Tensor dzPre = dz * z * (1 - z);
      Tensor dgit = dgi[t];
      dgit.narrow(1, 0, hidden).copy_(drPre);
      dgit.narrow(1, hidden, hidden).copy_(dzPre);
      dgit.narrow(1, 2 * hidden, hidden).copy_(dnPre);
      Tensor dght = dgh[t];
      dght.narrow(1, 0, 2 * hidden).copy_(dgit.narrow(1, 0, 2 * hidden));
      Tensor dghn = dght.narrow(1, 2 * hidden, hidden);
      torch::mul_out(dghn, dnPre, r);
      // to the previous state: directly and through W_hh, then the reset
      dh = torch::addmm(dh * z, dght, whh) * mask[t];
    }
    const Tensor dghFlat = dgh.view({steps * batch, 3 * hidden});
    const Tensor dwhh = dghFlat.t().mm(hprev.view({steps * batch, hidden}));
    const Tensor dbhh = dghFlat.sum(0);
    return {dgi, dh, dwhh, dbhh, Tensor()};
  }
};

}  // namespace

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
  const auto w = gru->all_weights();  // w_ih, w_hh, b_ih, b_hh
  // the input projection of every step is one matrix product
  const torch::Tensor gi = torch::linear(x, w[0], w[2]);
  const torch::Tensor out = GruRecurrence::apply(
      gi, h0, w[1], w[3], notDone.to(x.scalar_type()).detach());
  return {out, out[steps - 1]};
}

}  // namespace vln::models
