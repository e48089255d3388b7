#pragma once
// Paths injected by CMake into every test, plus small helpers shared by tests.

#include <filesystem>
#include <string>

namespace vln::test {

/// tests/data_files: small fixtures the repository makes itself.
std::filesystem::path testDataPath();
/// ../shared/fixtures beside the checkout: real-data samples that may be
/// absent (tests GTEST_SKIP() then).
std::filesystem::path sharedFixturesPath();
/// testDataPath() / "r2r" / name: small hand-made R2R_VLNCE files.
std::filesystem::path r2rFixture(const std::string& name);
/// sharedFixturesPath() / "r2r_vlnce_v1-3_preprocessed" / name: samples of
/// the real R2R_VLNCE release (may be absent).
std::filesystem::path realR2rSample(const std::string& name);
/// The repository root.
std::filesystem::path sourcePath();
/// The CMake build tree (binaries are in bin/).
std::filesystem::path binaryPath();

/// A fresh empty directory under the system temp dir, removed when the
/// TempDir is destroyed.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  /// path() / name.
  std::filesystem::path operator/(const std::string& name) const {
    return path_ / name;
  }

 private:
  std::filesystem::path path_;
};

/// Writes `contents` to `file` (creating parents) and returns the path.
std::filesystem::path writeText(const std::filesystem::path& file,
                                const std::string& contents);

/// Runs a shell command, returns its exit status; stdout+stderr go to
/// `output` when non-null.
int runCommand(const std::string& command, std::string* output = nullptr);

}  // namespace vln::test
