#include "common/App.h"

#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <exception>

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

void setBlasThreadsEnv(int threads) {
  VLN_CHECK_ARG(threads >= 1, "setBlasThreadsEnv(): threads must be >= 1, got ",
                threads);
  std::string value = std::to_string(threads);
  ::setenv("OMP_NUM_THREADS", value.c_str(), 1);
  ::setenv("OPENBLAS_NUM_THREADS", value.c_str(), 1);
}

}  // namespace vln::common
