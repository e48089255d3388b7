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

bool cpuHasAvx2Fma() {
#if defined(__x86_64__) || defined(__i386__)
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
  return false;
#endif
}

bool setAndNotZero(const char* value) {
  return value != nullptr && std::string_view(value) != "0";
}

}  // namespace

bool nativeCpuDispatch() {
  return setAndNotZero(std::getenv("VLN_NATIVE_DISPATCH"));
}

std::vector<RuntimeVariable> numericalRuntimeVariables(
    const std::function<const char*(const char*)>& env, bool cpuHasAvx2Fma,
    OmpWait wait) {
  std::vector<RuntimeVariable> wanted;
  if (!setAndNotZero(env("VLN_NATIVE_DISPATCH")) && cpuHasAvx2Fma) {
    wanted.push_back({"ATEN_CPU_CAPABILITY", "avx2", false});
    wanted.push_back({"DNNL_MAX_CPU_ISA", "AVX2", false});
    wanted.push_back({"ONEDNN_MAX_CPU_ISA", "AVX2", false});
    wanted.push_back({"OPENBLAS_CORETYPE", "Haswell", true});
  }
  // how OpenMP threads wait is the user's choice when they made one
  const bool userChose =
      env("OMP_WAIT_POLICY") != nullptr || env("GOMP_SPINCOUNT") != nullptr;
  if (!userChose && wait == OmpWait::kShortSpin)
    wanted.push_back({"GOMP_SPINCOUNT", "10000", true});
  return wanted;
}

void pinNumericalRuntime(const std::string& program, char** argv,
                         OmpWait wait) {
  const auto wanted = numericalRuntimeVariables(
      [](const char* name) { return std::getenv(name); }, cpuHasAvx2Fma(),
      wait);
  bool restart = false;
  for (const RuntimeVariable& variable : wanted) {
    const char* current = std::getenv(variable.name.c_str());
    if (current != nullptr && variable.value == current) continue;
    ::setenv(variable.name.c_str(), variable.value.c_str(), /*overwrite=*/1);
    restart = restart || variable.read_at_load;
  }
  // The marker stops a second restart if a variable does not stick. It
  // holds the process id, which execv keeps: a child this process starts
  // (a test running a binary with other variables) restarts on its own.
  const std::string self = std::to_string(::getpid());
  const char* marker = std::getenv("VLN_RUNTIME_PINNED");
  if (!restart || (marker != nullptr && self == marker)) return;
  ::setenv("VLN_RUNTIME_PINNED", self.c_str(), /*overwrite=*/1);
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
