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
#include <vector>

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

/// One entry of an archive, its data uncompressed.
struct ZipEntry {
  std::string name;
  std::string data;
};

/// Bounds readZipEntries() puts on an archive before inflating anything, so
/// that a zip bomb (a small archive recording huge entries) is refused
/// instead of exhausting memory.
struct ZipReadLimits {
  int64_t max_entries = 4096;
  int64_t max_total_bytes = int64_t{1} << 30;  ///< uncompressed, all entries
};

/// Checks `bytes` as verifyZipIntegrity() does and returns its entries in
/// central-directory order. Throws std::runtime_error naming `source` (and
/// the entry) on damage or when the archive exceeds `limits`.
std::vector<ZipEntry> readZipEntries(std::string_view bytes,
                                     std::string_view source,
                                     const ZipReadLimits& limits = {});

}  // namespace vln::common
