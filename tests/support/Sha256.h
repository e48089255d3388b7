#pragma once
// SHA-256 (FIPS 180-4) of bytes and files, for the tests that compare
// generated files with recorded hashes (tests/data_files/world/*.sha256).
// A plain byte-at-a-time implementation, not tuned for speed: the default
// world's 41 frozen files hash in well under a second.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace vln::test {

/// The SHA-256 of `bytes` as 64 lowercase hex digits (what sha256sum prints).
std::string sha256Hex(std::string_view bytes);

/// The SHA-256 of the contents of `file` as 64 lowercase hex digits. Throws
/// std::runtime_error naming the file when it cannot be read.
std::string sha256File(const std::filesystem::path& file);

}  // namespace vln::test
