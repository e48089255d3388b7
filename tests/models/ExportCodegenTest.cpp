// Tests src/models/ExportCodegen.cpp, the pieces both TorchScript exports
// are generated from: literals and names, tensor registration, compiling,
// the instruction encoder and GRU step emitters against the C++ modules,
// and the encoder fit check. (ExportTest and WaypointExportTest check
// whole policies.)

#include "models/ExportCodegen.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>

#include "ModelTestUtil.h"
#include "models/InstructionEncoder.h"
#include "models/MaskedGru.h"

namespace vln::models {
namespace {

using ::testing::HasSubstr;

TEST(ExportCodegenTest, LiteralsAndNames) {
  EXPECT_EQ(flatName("policy.state_encoder.gru.weight_ih_l0"),
            "policy__state_encoder__gru__weight_ih_l0");
  // integral values still read as floats in TorchScript
  EXPECT_EQ(floatLiteral(3.0), "3.0");
  EXPECT_EQ(floatLiteral(-2.0), "-2.0");
  // full precision: the literal parses back to the same double
  for (double v : {0.1, 1.0 / 3.0, 6.283185307179586, 1e-12, 12345678.9})
    EXPECT_EQ(std::strtod(floatLiteral(v).c_str(), nullptr), v) << v;
}

TEST(ExportCodegenTest, RegisteredTensorsAreCpuFloatCopiesWithBuffersKept) {
  torch::nn::BatchNorm2d bn(3);
  bn->to(torch::kFloat64);
  torch::jit::Module root("__torch__.Root");
  ScriptWriter w;
  w.addTensors(root, *bn, "bn.");
  EXPECT_TRUE(w.has("bn.weight"));
  EXPECT_TRUE(w.has("bn.running_mean"));
  EXPECT_FALSE(w.has("bn.missing"));
  EXPECT_EQ(w.ref("bn.running_var"), "self.bn__running_var");
  const torch::Tensor weight = root.attr("bn__weight").toTensor();
  EXPECT_EQ(weight.scalar_type(), torch::kFloat32);
  // a copy: changing the module later does not change the export
  {
    torch::NoGradGuard noGrad;
    bn->weight.fill_(7.0);
  }
  EXPECT_TRUE(torch::equal(weight, torch::ones({3})));
  // running statistics stay buffers, the affine weights parameters
  int buffers = 0, parameters = 0;
  for (const auto& b : root.named_buffers())
    buffers += b.name == "bn__running_mean";
  for (const auto& p : root.named_parameters())
    parameters += p.name == "bn__weight";
  EXPECT_EQ(buffers, 1);
  EXPECT_EQ(parameters, 1);
}

TEST(ExportCodegenTest, LinesCompileWithDtypesAndIndentation) {
  torch::nn::Linear fc(4, 2);
  torch::jit::Module root("__torch__.Root");
  ScriptWriter w;
  w.addTensors(root, *fc, "fc.");
  w.line(0, "def forward(self, x: Tensor) -> Tuple[Tensor, Tensor, Tensor]:");
  w.line(1, "y = " + linear(w, "fc", "x.to({f32})"));
  w.line(1, "i = torch.zeros([2], dtype={i64})");
  w.line(1, "b = torch.ones([2], dtype={bool})");
  w.line(1, "return y, i, b");
  w.compileInto(root, "ExportCodegenTest");
  const torch::Tensor x = torch::randn({3, 4}, torch::kFloat64);
  const auto out = root.forward({x}).toTuple();
  torch::NoGradGuard noGrad;
  EXPECT_TRUE(torch::allclose(out->elements()[0].toTensor(),
                              fc(x.to(torch::kFloat32))));
  EXPECT_EQ(out->elements()[1].toTensor().scalar_type(), torch::kInt64);
  EXPECT_EQ(out->elements()[2].toTensor().scalar_type(), torch::kBool);
}

// encode_instruction() equals InstructionEncoderImpl::forward() at every
// real token, for the BiLSTM (CMA) and the LSTM (Seq2Seq), with extra PAD
TEST(ExportCodegenTest, InstructionEncoderMatchesTheModule) {
  for (PolicyType type : {PolicyType::kCma, PolicyType::kSeq2Seq}) {
    SCOPED_TRACE(policyName(type));
    torch::manual_seed(31);
    const ModelConfig c = test::tinyConfig(type);
    InstructionEncoder encoder(c);
    torch::jit::Module root("__torch__.Root");
    ScriptWriter w;
    w.addTensors(root, *encoder, "enc.");
    emitInstructionEncoder(w, c, "enc");
    w.compileInto(root, "ExportCodegenTest");
    const torch::Tensor tokens = test::randomTokens({4, 1, 6}, 9, c.vocab_size);
    torch::NoGradGuard noGrad;
    const InstructionStates expected = encoder(tokens);
    const auto out = root.get_method("encode_instruction")({tokens}).toTuple();
    EXPECT_TRUE(torch::allclose(out->elements()[0].toTensor(), expected.states,
                                1e-5, 1e-6));
    EXPECT_TRUE(torch::equal(out->elements()[1].toTensor(), expected.mask));
    EXPECT_TRUE(torch::allclose(out->elements()[2].toTensor(), expected.last,
                                1e-5, 1e-6));
  }
}

// one gruStep() equals a MaskedGru step, resetting where the mask is 0
TEST(ExportCodegenTest, GruStepResetsAtEpisodeStarts) {
  torch::manual_seed(32);
  MaskedGru gru(5, 6);
  {
    torch::NoGradGuard noGrad;
    for (auto& p : gru->parameters()) p.uniform_(-0.5, 0.5);
  }
  torch::jit::Module root("__torch__.Root");
  ScriptWriter w;
  w.addTensors(root, *gru, "g.");
  w.line(0,
         "def forward(self, x: Tensor, h: Tensor, not_done: Tensor) -> "
         "Tensor:");
  w.line(1, "m = not_done.unsqueeze(1)");
  w.line(1, "return " + gruStep(w, "g", "x", "h", "m"));
  w.compileInto(root, "ExportCodegenTest");
  const torch::Tensor x = torch::randn({3, 5});
  const torch::Tensor h = torch::randn({3, 6});
  const torch::Tensor notDone = torch::tensor({1.0f, 0.0f, 1.0f});
  torch::NoGradGuard noGrad;
  const torch::Tensor expected =
      gru(x.unsqueeze(0), h, notDone.unsqueeze(0)).second;
  EXPECT_TRUE(torch::allclose(root.forward({x, h, notDone}).toTensor(),
                              expected, 1e-5, 1e-6));
}

TEST(ExportCodegenTest, EncoderFitIsCheckedByModalityAndShape) {
  const ModelConfig c = test::tinyConfig(PolicyType::kCma);
  EXPECT_NO_THROW(checkEncoderFits(c, c, "who()"));
  ModelConfig other = c;
  other.no_depth = true;
  try {
    checkEncoderFits(c, other, "who()");
    ADD_FAILURE() << "a missing depth encoder must be refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("who(): "));
    EXPECT_THAT(e.what(), HasSubstr("model.no_depth"));
  }
  other = c;
  other.depth_encoder = EncoderType::kResNet18;
  EXPECT_THROW(checkEncoderFits(c, other, "who()"), std::invalid_argument);
}

}  // namespace
}  // namespace vln::models
