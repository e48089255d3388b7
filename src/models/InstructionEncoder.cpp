#include "models/InstructionEncoder.h"

#include <ATen/CPUGeneratorImpl.h>

#include "common/Check.h"

namespace vln::models {

InstructionEncoderImpl::InstructionEncoderImpl(const ModelConfig& config)
    : vocabSize_(config.vocab_size),
      featureDim_(config.text_feature_dim),
      textFeatures_(config.usesTextFeatures()),
      bidirectional_(config.policy == PolicyType::kCma) {
  // PAD (0) stays a zero vector: it only ever meets masked positions. Text
  // features enter the LSTM as they are (VLN-CE's RxR encoder has no
  // embedding layer)
  if (!textFeatures_) {
    embedding = register_module(
        "embedding",
        torch::nn::Embedding(
            torch::nn::EmbeddingOptions(config.vocab_size, config.embedding_dim)
                .padding_idx(0)));
    embedding->weight.set_requires_grad(config.fine_tune_embeddings);
  }
  lstm = register_module(
      "lstm",
      torch::nn::LSTM(torch::nn::LSTMOptions(config.instructionInputSize(),
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

torch::Tensor InstructionEncoderImpl::featureLengths(
    const torch::Tensor& features) const {
  VLN_CHECK_ARG(features.defined(),
                "InstructionEncoder::forward(): model.instruction_features is "
                "rxr_text, expected text features [B, L, ",
                featureDim_, "], got an undefined tensor");
  VLN_CHECK_ARG(features.dim() == 3 && features.size(1) > 0 &&
                    features.size(2) == featureDim_ &&
                    features.is_floating_point(),
                "InstructionEncoder::forward(): model.instruction_features is "
                "rxr_text, expected float text features [B, L, ",
                featureDim_, "] (model.text_feature_dim), got ",
                features.sizes(), " of ", features.scalar_type());
  // the last non-zero row ends the instruction; zero rows after it pad
  const torch::Tensor real = (features != 0).any(/*dim=*/2).to(torch::kCPU);
  const torch::Tensor positions =
      torch::arange(1, real.size(1) + 1, torch::kInt64).unsqueeze(0);
  const torch::Tensor lens = (positions * real).amax(/*dim=*/1);
  VLN_CHECK_ARG(lens.min().item<int64_t>() > 0,
                "InstructionEncoder::forward(): the text features of row ",
                lens.argmin().item<int64_t>(),
                " are all zero (an instruction without tokens)");
  return lens;
}

InstructionStates InstructionEncoderImpl::forward(
    const torch::Tensor& instruction) {
  if (textFeatures_) {
    const torch::Tensor lens = featureLengths(instruction);
    // in the LSTM's dtype (float32, or float64 in gradient checks)
    return encode(instruction.to(lstm->parameters().front().scalar_type()),
                  lens);
  }
  const torch::Tensor lens = lengths(instruction);
  return encode(embedding(instruction), lens);
}

InstructionStates InstructionEncoderImpl::encode(const torch::Tensor& embedded,
                                                 const torch::Tensor& lens) {
  const auto packed = torch::nn::utils::rnn::pack_padded_sequence(
      embedded, lens, /*batch_first=*/true, /*enforce_sorted=*/false);
  auto [output, state] = lstm->forward_with_packed_input(packed);
  InstructionStates out;
  out.states = std::get<0>(
      torch::nn::utils::rnn::pad_packed_sequence(output, /*batch_first=*/true));
  const int64_t maxLen = out.states.size(1);
  out.mask = (torch::arange(maxLen).unsqueeze(0) < lens.unsqueeze(1))
                 .to(embedded.device());
  out.last = std::get<0>(state)[0];
  return out;
}

void InstructionEncoderImpl::setWordEmbeddings(const torch::Tensor& matrix) {
  VLN_CHECK_ARG(!textFeatures_,
                "InstructionEncoder::setWordEmbeddings(): "
                "model.instruction_features is rxr_text, the encoder reads "
                "text features and has no word embedding");
  VLN_CHECK_ARG(matrix.defined() && matrix.dim() == 2 &&
                    matrix.sizes() == embedding->weight.sizes(),
                "InstructionEncoder::setWordEmbeddings(): expected a [",
                embedding->weight.size(0), ", ", embedding->weight.size(1),
                "] matrix (model.vocab_size x model.embedding_dim), got ",
                matrix.defined() ? matrix.sizes() : torch::IntArrayRef{});
  torch::NoGradGuard noGrad;
  embedding->weight.copy_(matrix);
}

torch::Tensor randomWordEmbeddings(int64_t vocab, int64_t dim, uint64_t seed) {
  VLN_CHECK_ARG(vocab >= 1 && dim >= 1,
                "randomWordEmbeddings(): vocab and dim must be >= 1, got ",
                vocab, " x ", dim);
  at::Generator generator = at::make_generator<at::CPUGeneratorImpl>(seed);
  torch::Tensor matrix = torch::randn({vocab, dim}, generator);
  matrix[0].zero_();
  return matrix;
}

}  // namespace vln::models
