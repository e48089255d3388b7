#pragma once
// Small helpers shared by tests of several modules: the build tree's
// binaries, reading files back, a free loopback port and the message of a
// thrown exception.

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace vln::test {

/// bin/<name> of the build tree under test.
std::string binary(const std::string& name);

/// The contents of `file` ("" when it cannot be read).
std::string readText(const std::filesystem::path& file);

/// The records of a JSON-lines file (metrics.jsonl, ...), in order; empty
/// lines are skipped.
std::vector<nlohmann::json> readJsonLines(const std::filesystem::path& file);

/// The number of entries directly in `dir`.
int countEntries(const std::filesystem::path& dir);

/// A TCP port nobody listens on right now (bound to loopback, then freed).
int freePort();

/// The message of the std::exception `f` throws, "" when it returns.
std::string errorOf(const std::function<void()>& f);

}  // namespace vln::test
