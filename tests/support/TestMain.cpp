// main() of every test executable: the tests compute with the kernels the
// project's binaries compute with. common::pinNumericalRuntime pins LibTorch,
// oneDNN and OpenBLAS to their AVX2 versions (where the CPU has AVX2 and FMA),
// so values a test compares to printed ones (PolicyGoldenTest) come from the
// same kernels on machines with and without AVX-512. Under CTest the variable
// OpenBLAS reads at load time is already set (tests/CMakeLists.txt), which
// spares each test process the restart; run by hand, a test binary restarts
// itself once. Listing the tests (CTest's discovery) computes nothing, so it
// does not restart either.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <string_view>

#include "common/App.h"

int main(int argc, char** argv) {
  const bool listing = std::any_of(argv, argv + argc, [](const char* arg) {
    return std::string_view(arg) == "--gtest_list_tests";
  });
  // the binaries a test runs choose their own OpenMP wait policy
  if (!listing)
    vln::common::pinNumericalRuntime(argv[0], argv,
                                     vln::common::OmpWait::kLibraryDefault);
  ::testing::InitGoogleMock(&argc, argv);
  return RUN_ALL_TESTS();
}
