#include "support/TestPaths.h"

#include <unistd.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <random>
#include <stdexcept>
#include <sys/wait.h>

namespace vln::test {

std::filesystem::path testDataPath() { return VLN_TEST_DATA_DIR; }
std::filesystem::path sharedFixturesPath() { return VLN_SHARED_FIXTURES_DIR; }
std::filesystem::path r2rFixture(const std::string& name) {
  return testDataPath() / "r2r" / name;
}
std::filesystem::path realR2rSample(const std::string& name) {
  return sharedFixturesPath() / "r2r_vlnce_v1-3_preprocessed" / name;
}
std::filesystem::path sourcePath() { return VLN_SOURCE_DIR; }
std::filesystem::path binaryPath() { return VLN_BINARY_DIR; }

TempDir::TempDir() {
  std::random_device device;
  std::mt19937_64 rng(device() ^ static_cast<uint64_t>(::getpid()));
  for (int attempt = 0; attempt < 100; ++attempt) {
    auto candidate = std::filesystem::temp_directory_path() /
                     ("vln-test-" + std::to_string(rng()));
    if (std::filesystem::create_directory(candidate)) {
      path_ = candidate;
      return;
    }
  }
  throw std::runtime_error("TempDir: cannot create a temporary directory");
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

std::filesystem::path writeText(const std::filesystem::path& file,
                                const std::string& contents) {
  if (file.has_parent_path())
    std::filesystem::create_directories(file.parent_path());
  std::ofstream out(file, std::ios::binary);
  out << contents;
  if (!out) throw std::runtime_error("writeText: cannot write " + file.string());
  return file;
}

int runCommand(const std::string& command, std::string* output) {
  std::string full = command + " 2>&1";
  FILE* pipe = ::popen(full.c_str(), "r");
  if (!pipe) return -1;
  std::array<char, 4096> buffer{};
  std::string collected;
  size_t n = 0;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0)
    collected.append(buffer.data(), n);
  int status = ::pclose(pipe);
  if (output) *output = collected;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace vln::test
