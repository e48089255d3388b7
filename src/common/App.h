#pragma once
// What every binary's main() shares: a process-wide signal policy, logging
// setup, and the top-level catch that turns exceptions into one clear line
// and a non-zero exit code.

#include <filesystem>
#include <functional>
#include <string>

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

/// Pins the numerical runtime of a LibTorch binary before it does anything
/// else (call first in main()). On an x86-64 CPU with AVX2 and FMA, the
/// kernels LibTorch (ATen), oneDNN and OpenBLAS pick at run time are pinned
/// to their AVX2 versions: they otherwise pick AVX-512 kernels where the CPU
/// has them, which sum in another order, so one config trained different
/// weights on two machines of one kind (docs/reliability.md, "Determinism"). With
/// `passiveOmpWait`, OpenMP threads sleep instead of spinning between ops
/// (evaluation: they took the cores from the rendering threads). OpenBLAS
/// and libgomp read their variables when they are loaded, before main(), so
/// the process restarts itself once (execv of /proc/self/exe) when one of
/// them was not yet set. VLN_NATIVE_DISPATCH=1 keeps every library's own
/// choice (fastest on AVX-512 machines; numbers then depend on the CPU).
void pinNumericalRuntime(const std::string& program, char** argv,
                         bool passiveOmpWait = false);

/// True when VLN_NATIVE_DISPATCH is set to anything but "0": every library
/// (LibTorch, oneDNN, OpenBLAS, Embree) then picks its kernels for this CPU.
bool nativeCpuDispatch();

/// Sets LibTorch-independent thread knobs used by BLAS/OpenMP (OMP, OpenBLAS)
/// to `threads` (>= 1) for this process.
void setBlasThreadsEnv(int threads);

}  // namespace vln::common
