#pragma once
// Integrity of zip archives before a library that trusts them parses them.
// LibTorch's archive reader (checkpoints, TorchScript tensor files) ignores
// the CRC-32 a zip records for every entry and hands damaged bytes to its
// TorchScript and pickle parsers, which crash on some of them (found by
// fuzzing: a SEGV in torch::jit::ScriptTypeParser on a flipped byte of an
// archive's code/ entry). Checking every entry first turns damage into an
// error that names the file and the entry.

#include <cstdint>
#include <string>
#include <string_view>

namespace vln::common {

/// What verifyZipIntegrity() checked.
struct ZipSummary {
  int64_t entries = 0;             ///< entries in the central directory
  int64_t uncompressed_bytes = 0;  ///< their data, uncompressed
};

/// Checks that `bytes` is a whole zip archive (PKWARE APPNOTE 6.3: end of
/// central directory, zip64 records when present) whose every entry's
/// local header agrees with the central directory and whose data, stored or
/// deflated, has the recorded size and CRC-32. Throws std::runtime_error
/// naming `source` and the entry on the first problem.
ZipSummary verifyZipIntegrity(std::string_view bytes, std::string_view source);

}  // namespace vln::common
