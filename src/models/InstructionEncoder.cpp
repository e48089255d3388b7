#include "models/InstructionEncoder.h"

#include "common/Check.h"

namespace vln::models {

InstructionEncoderImpl::InstructionEncoderImpl(const ModelConfig& config)
    : vocabSize_(config.vocab_size),
      bidirectional_(config.policy == PolicyType::kCma) {
  // PAD (0) stays a zero vector: it only ever meets masked positions
  embedding = register_module(
      "embedding",
      torch::nn::Embedding(
          torch::nn::EmbeddingOptions(config.vocab_size, config.embedding_dim)
              .padding_idx(0)));
  embedding->weight.set_requires_grad(config.fine_tune_embeddings);
  lstm = register_module(
      "lstm",
      torch::nn::LSTM(torch::nn::LSTMOptions(config.embedding_dim,
                                             config.instruction_hidden_size)
                          .bidirectional(bidirectional_)));
}

torch::Tensor InstructionEncoderImpl::lengths(
    const torch::Tensor& tokens) const {
  VLN_CHECK_ARG(tokens.defined() && tokens.dim() == 2 && tokens.size(1) > 0 &&
                    tokens.scalar_type() == torch::kInt64,
                "InstructionEncoder::forward(): expected int64 tokens [B, L], "
                "got ",
                tokens.defined() ? tokens.sizes() : torch::IntArrayRef{});
  const torch::Tensor cpu = tokens.to(torch::kCPU);
  const int64_t lo = cpu.min().item<int64_t>();
  const int64_t hi = cpu.max().item<int64_t>();
  VLN_CHECK_ARG(lo >= 0 && hi < vocabSize_,
                "InstructionEncoder::forward(): token id ", lo < 0 ? lo : hi,
                " is outside the vocabulary [0, ", vocabSize_, ")");
  const torch::Tensor real = cpu != 0;
  const torch::Tensor lens = real.sum(1);
  // packing relies on the real tokens being a prefix of each row
  const torch::Tensor prefix =
      torch::arange(cpu.size(1)).unsqueeze(0) < lens.unsqueeze(1);
  VLN_CHECK_ARG(torch::equal(real, prefix),
                "InstructionEncoder::forward(): every row must be tokens "
                "followed by PAD (0), found a PAD before a real token");
  VLN_CHECK_ARG(lens.min().item<int64_t>() > 0,
                "InstructionEncoder::forward(): an instruction has no tokens "
                "(row ",
                lens.argmin().item<int64_t>(), ")");
  return lens;
}

InstructionStates InstructionEncoderImpl::forward(const torch::Tensor& tokens) {
  const torch::Tensor lens = lengths(tokens);
  const torch::Tensor embedded = embedding(tokens);  // [B, L, E]
  const auto packed = torch::nn::utils::rnn::pack_padded_sequence(
      embedded, lens, /*batch_first=*/true, /*enforce_sorted=*/false);
  auto [output, state] = lstm->forward_with_packed_input(packed);
  InstructionStates out;
  out.states = std::get<0>(
      torch::nn::utils::rnn::pad_packed_sequence(output, /*batch_first=*/true));
  const int64_t maxLen = out.states.size(1);
  out.mask = (torch::arange(maxLen).unsqueeze(0) < lens.unsqueeze(1))
                 .to(tokens.device());
  out.last = std::get<0>(state)[0];
  return out;
}

void InstructionEncoderImpl::setWordEmbeddings(const torch::Tensor& matrix) {
  VLN_CHECK_ARG(matrix.defined() && matrix.dim() == 2 &&
                    matrix.sizes() == embedding->weight.sizes(),
                "InstructionEncoder::setWordEmbeddings(): expected a [",
                embedding->weight.size(0), ", ", embedding->weight.size(1),
                "] matrix (model.vocab_size x model.embedding_dim), got ",
                matrix.defined() ? matrix.sizes() : torch::IntArrayRef{});
  torch::NoGradGuard noGrad;
  embedding->weight.copy_(matrix);
}

}  // namespace vln::models
