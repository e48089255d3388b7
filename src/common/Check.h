#pragma once
// The project's error policy, written once.
//
//  - Programmer bugs (broken invariants inside the code): VLN_ASSERT, which
//    prints the location and aborts. Never used for anything a user can cause.
//  - Bad user input or data (config, files, meshes, checkpoints, episodes):
//    throw std::invalid_argument (a malformed value) or std::runtime_error (an
//    environment problem: missing file, I/O failure, disk full). Messages
//    follow "Class::method(): what was wrong, got X" and name the file, the
//    episode and the field where there is one. VLN_CHECK_ARG / VLN_CHECK_IO
//    build such exceptions from streamable parts.
//  - Tensor contracts inside models: TORCH_CHECK with the expected shape.
//  - Numeric faults at run time (NaN loss, blocked move): detected, counted
//    and recovered from by the caller, not thrown.
// Binaries catch std::exception in main(), print what() and return non-zero.

#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <string>

namespace vln {

/// Concatenates any streamable values into one string (for error messages).
template <class... Args>
std::string strCat(const Args&... args) {
  std::ostringstream out;
  (out << ... << args);
  return out.str();
}

[[noreturn]] inline void assertFailed(const char* expr, const char* file,
                                      int line) {
  std::fprintf(stderr, "%s:%d: internal error: assertion '%s' failed\n", file,
               line, expr);
  std::abort();
}

}  // namespace vln

/// Aborts on a broken internal invariant (a bug, never bad input).
#define VLN_ASSERT(cond) \
  ((cond) ? static_cast<void>(0) : ::vln::assertFailed(#cond, __FILE__, __LINE__))

/// Throws std::invalid_argument built from the remaining arguments unless cond.
#define VLN_CHECK_ARG(cond, ...)                               \
  do {                                                         \
    if (!(cond)) throw std::invalid_argument(::vln::strCat(__VA_ARGS__)); \
  } while (false)

/// Throws std::runtime_error built from the remaining arguments unless cond.
#define VLN_CHECK_IO(cond, ...)                                \
  do {                                                         \
    if (!(cond)) throw std::runtime_error(::vln::strCat(__VA_ARGS__)); \
  } while (false)
