#include "common/App.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>
#include <string>

namespace vln::common {
namespace {

// An environment of the given variables (nothing else is set).
auto environment(std::map<std::string, std::string> variables) {
  return [variables = std::move(variables)](const char* name) -> const char* {
    const auto it = variables.find(name);
    return it == variables.end() ? nullptr : it->second.c_str();
  };
}

std::map<std::string, std::string> asMap(
    const std::vector<RuntimeVariable>& variables) {
  std::map<std::string, std::string> out;
  for (const auto& v : variables) out[v.name] = v.value;
  return out;
}

using ::testing::Contains;
using ::testing::Key;
using ::testing::Not;
using ::testing::Pair;

TEST(NumericalRuntimeVariables, ShortSpinUnlessTheUserChose) {
  const auto pinned = asMap(numericalRuntimeVariables(
      environment({}), /*cpuHasAvx2Fma=*/false, OmpWait::kShortSpin));
  EXPECT_THAT(pinned, Contains(Pair("GOMP_SPINCOUNT", "10000")));
  EXPECT_THAT(pinned, Not(Contains(Key("OMP_WAIT_POLICY"))));

  for (const char* choice : {"OMP_WAIT_POLICY", "GOMP_SPINCOUNT"}) {
    const auto kept = asMap(numericalRuntimeVariables(
        environment({{choice, "ACTIVE"}}), false, OmpWait::kShortSpin));
    EXPECT_THAT(kept, Not(Contains(Key("GOMP_SPINCOUNT")))) << choice;
    EXPECT_THAT(kept, Not(Contains(Key("OMP_WAIT_POLICY")))) << choice;
  }
}

TEST(NumericalRuntimeVariables, LibraryDefaultSetsNoWaitVariable) {
  const auto pinned = asMap(numericalRuntimeVariables(
      environment({}), /*cpuHasAvx2Fma=*/true, OmpWait::kLibraryDefault));
  EXPECT_THAT(pinned, Not(Contains(Key("GOMP_SPINCOUNT"))));
  EXPECT_THAT(pinned, Not(Contains(Key("OMP_WAIT_POLICY"))));
  EXPECT_THAT(pinned, Contains(Key("OPENBLAS_CORETYPE")));
}

TEST(NumericalRuntimeVariables, Avx2KernelsUnlessNativeDispatch) {
  const auto pinned = asMap(numericalRuntimeVariables(
      environment({}), /*cpuHasAvx2Fma=*/true, OmpWait::kShortSpin));
  EXPECT_THAT(pinned, Contains(Pair("ATEN_CPU_CAPABILITY", "avx2")));
  EXPECT_THAT(pinned, Contains(Pair("OPENBLAS_CORETYPE", "Haswell")));

  const auto native = asMap(numericalRuntimeVariables(
      environment({{"VLN_NATIVE_DISPATCH", "1"}}), true, OmpWait::kShortSpin));
  EXPECT_THAT(native, Not(Contains(Key("ATEN_CPU_CAPABILITY"))));
  EXPECT_THAT(native, Contains(Key("GOMP_SPINCOUNT")));

  // "0" means off, as nativeCpuDispatch() reads it
  const auto off = asMap(numericalRuntimeVariables(
      environment({{"VLN_NATIVE_DISPATCH", "0"}}), true, OmpWait::kShortSpin));
  EXPECT_THAT(off, Contains(Key("ATEN_CPU_CAPABILITY")));
  // without AVX2 and FMA there is nothing to pin the kernels to
  const auto older = asMap(
      numericalRuntimeVariables(environment({}), false, OmpWait::kShortSpin));
  EXPECT_THAT(older, Not(Contains(Key("ATEN_CPU_CAPABILITY"))));
}

}  // namespace
}  // namespace vln::common
