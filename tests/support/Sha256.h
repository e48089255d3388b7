#pragma once
// SHA-256 (FIPS 180-4) of bytes and files, for the tests that compare
// generated files with recorded hashes (tests/data_files/world/*.sha256).
// Not for speed: about 200 MB/s, enough for the few MB a world's
// evaluation files hold.

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
