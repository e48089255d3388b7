#pragma once
// Whole-file I/O with the project's durability rules: every write goes to a
// temporary file in the same directory, is fsync'ed, then renamed over the
// target, so a crash or a full disk never leaves a half-written file behind
// and never destroys the previous version.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace vln::common {

/// Contents of `file`; transparently gunzips when the file starts with the
/// gzip magic bytes. Throws std::runtime_error naming the file when it is
/// missing, unreadable, or a truncated/corrupt gzip stream.
std::string readFile(const std::filesystem::path& file);

/// True when `path` ends in ".gz".
bool isGzipPath(const std::filesystem::path& path);

/// Atomically replaces `file` with `contents` (gzip-compressed when the name
/// ends in .gz). Creates missing parent directories. Throws
/// std::runtime_error naming the file on any failure (ENOSPC, EFBIG, ...),
/// leaving the previous file untouched.
void writeFileAtomic(const std::filesystem::path& file,
                     std::string_view contents);

/// Writes `contents` to `file` (creating missing parent directories)
/// without fsync: for the files of a folder that is written under a
/// temporary name, made durable as a whole with syncFileSystem() and then
/// renamed into place (e.g. an observation dump's episode), where one sync
/// per folder replaces one per file. Throws std::runtime_error naming the
/// file.
void writeFileUnsynced(const std::filesystem::path& file,
                       std::string_view contents);

/// Flushes every pending write of the file system holding `path` to disk
/// (syncfs(2)). Throws std::runtime_error naming the path when it cannot be
/// opened or synced.
void syncFileSystem(const std::filesystem::path& path);

/// Removes the temporaries writeFileAtomic() leaves when its process is
/// killed between creating and renaming them ("<name>.tmp.<pid>.<n>") from
/// `dir` and its subdirectories, skipping those of processes still running.
/// Returns the removed paths. A missing `dir` removes nothing.
std::vector<std::filesystem::path> removeStaleTemporaries(
    const std::filesystem::path& dir);

/// gzip-compresses `data` (RFC 1952 container, zlib level `level`).
std::string gzipCompress(std::string_view data, int level = 6);

/// Inflates a gzip stream; `name` is used in errors. Throws on corruption or
/// truncation.
std::string gzipDecompress(std::string_view data, std::string_view name);

/// fsyncs a directory so that a rename inside it is durable.
void syncDirectory(const std::filesystem::path& dir);

}  // namespace vln::common
