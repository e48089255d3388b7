#pragma once
// What every binary's main() shares: a process-wide signal policy, logging
// setup, and the top-level catch that turns exceptions into one clear line
// and a non-zero exit code.

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace vln::common {

/// Runs `body` as the program `program`: ignores SIGXFSZ and SIGPIPE (so a
/// file-size limit or a closed pipe surfaces as an error on write instead of
/// killing the process), catches std::exception, prints "<program>: error:
/// <what>" to stderr and returns 1; otherwise returns body's result.
int runMain(const std::string& program, const std::function<int()>& body);

/// Configures spdlog: console sink plus, when `logFile` is non-empty, an
/// appending file sink. `level` is one of trace, debug, info, warn, error.
void initLogging(const std::filesystem::path& logFile = {},
                 const std::string& level = "info");

/// How the OpenMP threads of LibTorch wait for work between ops, unless the
/// user chose (OMP_WAIT_POLICY or GOMP_SPINCOUNT set).
enum class OmpWait {
  /// Spin 10,000 rounds, then sleep (GOMP_SPINCOUNT=10000). libgomp's
  /// default spins 300,000 rounds, long enough to take the cores from the
  /// threads rendering between policy steps; sleeping at once
  /// (OMP_WAIT_POLICY=PASSIVE) makes every small op of an update wait for
  /// a wake-up. On the 2-core machine a short DAgger run took 113 s this
  /// way, 135 s with the default and 148 s with PASSIVE
  /// (docs/performance.md, "OpenMP wait policy"). Several processes side by
  /// side still want PASSIVE, which the user sets.
  kShortSpin,
  /// libgomp's own default: no variable, so no restart for it (the test
  /// executables, which CTest starts by the hundred: tests/support/TestMain.cpp;
  /// a restart costs each about 0.8 s, tests/CMakeLists.txt).
  kLibraryDefault,
};

/// An environment variable pinNumericalRuntime() sets, and whether a
/// library reads it only when it is loaded (so setting it is too late for
/// the running process image).
struct RuntimeVariable {
  std::string name;
  std::string value;
  bool read_at_load = false;
};

/// The variables pinNumericalRuntime() wants, given the environment (`env`
/// returns a variable's value, nullptr when unset) and whether the CPU has
/// AVX2 and FMA.
std::vector<RuntimeVariable> numericalRuntimeVariables(
    const std::function<const char*(const char*)>& env, bool cpuHasAvx2Fma,
    OmpWait wait);

/// Pins the numerical runtime of a LibTorch binary before it does anything
/// else (call first in main()). On an x86-64 CPU with AVX2 and FMA, the
/// kernels LibTorch (ATen), oneDNN and OpenBLAS pick at run time are pinned
/// to their AVX2 versions: they otherwise pick AVX-512 kernels where the CPU
/// has them, which sum in another order, so one config trained different
/// weights on two machines of one kind (docs/reliability.md, "Determinism").
/// `wait` sets how OpenMP threads wait between ops (OmpWait). OpenBLAS
/// and libgomp read their variables when they are loaded, before main(), so
/// the process restarts itself once (execv of /proc/self/exe) when one of
/// them was not yet set. VLN_NATIVE_DISPATCH=1 keeps every library's own
/// choice of kernels (fastest on AVX-512 machines; numbers then depend on
/// the CPU).
void pinNumericalRuntime(const std::string& program, char** argv,
                         OmpWait wait = OmpWait::kShortSpin);

/// True when VLN_NATIVE_DISPATCH is set to anything but "0": every library
/// (LibTorch, oneDNN, OpenBLAS, Embree) then picks its kernels for this CPU.
bool nativeCpuDispatch();

/// Sets LibTorch-independent thread knobs used by BLAS/OpenMP (OMP, OpenBLAS)
/// to `threads` (>= 1) for this process.
void setBlasThreadsEnv(int threads);

}  // namespace vln::common
