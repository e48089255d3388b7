#pragma once
// Shared harness of the libFuzzer targets: a private scratch directory, the
// fuzz input written to a file there (the readers under test take paths),
// and the project's error policy as the oracle: std::invalid_argument and
// std::runtime_error (and their subclasses) are the documented reactions to
// bad input; any other exception is a finding and aborts with its type and
// message, as do crashes and sanitizer reports.

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <typeinfo>

namespace vln::fuzz {

/// A per-process scratch directory under $TMPDIR (or /tmp), created on
/// first use and removed at exit.
inline const std::filesystem::path& scratchDir() {
  static const std::filesystem::path dir = [] {
    const char* base = std::getenv("TMPDIR");
    std::string pattern =
        std::string(base && *base ? base : "/tmp") + "/vln-fuzz-XXXXXX";
    if (::mkdtemp(pattern.data()) == nullptr) {
      std::perror("vln fuzz: mkdtemp");
      std::abort();
    }
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(scratchDir(), ec);
    });
    return std::filesystem::path(pattern);
  }();
  return dir;
}

/// Writes the fuzz input to scratchDir() / name (plain, non-atomic write:
/// the file is private) and returns its path.
inline std::filesystem::path writeInput(std::string_view name,
                                        const uint8_t* data, size_t size) {
  std::filesystem::path file = scratchDir() / name;
  std::FILE* out = std::fopen(file.c_str(), "wb");
  if (out == nullptr || (size > 0 && std::fwrite(data, 1, size, out) != size) ||
      std::fclose(out) != 0) {
    std::perror("vln fuzz: writing the input");
    std::abort();
  }
  return file;
}

/// Runs `body`; documented exceptions are expected outcomes, anything else
/// aborts naming the exception type (a finding).
template <class Body>
void expectDocumentedErrors(Body&& body) {
  try {
    body();
  } catch (const std::invalid_argument&) {
  } catch (const std::runtime_error&) {
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vln fuzz: undocumented exception %s: %s\n",
                 typeid(e).name(), e.what());
    std::abort();
  } catch (...) {
    std::fprintf(stderr, "vln fuzz: non-std exception\n");
    std::abort();
  }
}

/// Silences logging (readers warn on odd but valid input).
inline void quietLogging() { spdlog::set_level(spdlog::level::off); }

}  // namespace vln::fuzz
