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

/// Sets LibTorch-independent thread knobs used by BLAS/OpenMP (OMP, OpenBLAS)
/// to `threads` (>= 1) for this process.
void setBlasThreadsEnv(int threads);

}  // namespace vln::common
