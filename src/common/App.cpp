#include "common/App.h"

#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string_view>
#include <vector>

#include <unistd.h>

#include "common/Check.h"

namespace vln::common {

int runMain(const std::string& program, const std::function<int()>& body) {
  std::signal(SIGXFSZ, SIG_IGN);
  std::signal(SIGPIPE, SIG_IGN);
  try {
    return body();
  } catch (const std::exception& e) {
    spdlog::default_logger()->flush();
    std::fprintf(stderr, "%s: error: %s\n", program.c_str(), e.what());
    return 1;
  }
}

void initLogging(const std::filesystem::path& logFile,
                 const std::string& level) {
  std::vector<spdlog::sink_ptr> sinks;
  sinks.push_back(std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
  if (!logFile.empty()) {
    std::error_code ec;
    if (logFile.has_parent_path())
      std::filesystem::create_directories(logFile.parent_path(), ec);
    sinks.push_back(std::make_shared<spdlog::sinks::basic_file_sink_mt>(
        logFile.string(), /*truncate=*/false));
  }
  auto logger =
      std::make_shared<spdlog::logger>("vln", sinks.begin(), sinks.end());
  auto parsed = spdlog::level::from_str(level);
  VLN_CHECK_ARG(parsed != spdlog::level::off || level == "off",
                "initLogging(): unknown log level '", level, "'");
  logger->set_level(parsed);
  logger->set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
  logger->flush_on(spdlog::level::info);
  spdlog::set_default_logger(logger);
}

namespace {

// A variable this process needs, and whether a library reads it only when
// it is loaded (so setting it now is too late for this process image).
struct PinnedVariable {
  const char* name;
  const char* value;
  bool readAtLoad;
};

bool cpuHasAvx2Fma() {
#if defined(__x86_64__) || defined(__i386__)
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
  return false;
#endif
}

}  // namespace

bool nativeCpuDispatch() {
  const char* native = std::getenv("VLN_NATIVE_DISPATCH");
  return native != nullptr && std::string_view(native) != "0";
}

void pinNumericalRuntime(const std::string& program, char** argv,
                         bool passiveOmpWait) {
  std::vector<PinnedVariable> wanted;
  if (!nativeCpuDispatch() && cpuHasAvx2Fma()) {
    wanted.push_back({"ATEN_CPU_CAPABILITY", "avx2", false});
    wanted.push_back({"DNNL_MAX_CPU_ISA", "AVX2", false});
    wanted.push_back({"ONEDNN_MAX_CPU_ISA", "AVX2", false});
    wanted.push_back({"OPENBLAS_CORETYPE", "Haswell", true});
  }
  // an explicit OMP_WAIT_POLICY is the user's choice
  if (passiveOmpWait && std::getenv("OMP_WAIT_POLICY") == nullptr)
    wanted.push_back({"OMP_WAIT_POLICY", "PASSIVE", true});

  bool restart = false;
  for (const PinnedVariable& variable : wanted) {
    const char* current = std::getenv(variable.name);
    if (current != nullptr && std::string_view(current) == variable.value)
      continue;
    ::setenv(variable.name, variable.value, /*overwrite=*/1);
    restart = restart || variable.readAtLoad;
  }
  // the marker stops a second restart if a variable does not stick
  if (!restart || std::getenv("VLN_RUNTIME_PINNED") != nullptr) return;
  ::setenv("VLN_RUNTIME_PINNED", "1", /*overwrite=*/1);
  ::execv("/proc/self/exe", argv);
  std::cerr << program
            << ": warning: could not restart with pinned OpenBLAS/OpenMP "
               "settings; numbers may differ from other machines and "
               "evaluation may be slow\n";
}

void setBlasThreadsEnv(int threads) {
  VLN_CHECK_ARG(threads >= 1, "setBlasThreadsEnv(): threads must be >= 1, got ",
                threads);
  std::string value = std::to_string(threads);
  ::setenv("OMP_NUM_THREADS", value.c_str(), 1);
  ::setenv("OPENBLAS_NUM_THREADS", value.c_str(), 1);
}

}  // namespace vln::common
