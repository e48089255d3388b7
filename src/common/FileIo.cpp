#include "common/FileIo.h"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "common/Check.h"

namespace vln::common {
namespace {

std::string errnoText(int err) { return std::strerror(err); }

bool hasGzipMagic(std::string_view data) {
  return data.size() >= 2 && static_cast<unsigned char>(data[0]) == 0x1f &&
         static_cast<unsigned char>(data[1]) == 0x8b;
}

// writes all bytes or throws with the errno text
void writeAll(int fd, std::string_view data, const std::string& name) {
  size_t done = 0;
  while (done < data.size()) {
    ssize_t n = ::write(fd, data.data() + done, data.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw std::runtime_error("writeFileAtomic(): cannot write '" + name +
                               "': " + errnoText(errno));
    }
    done += static_cast<size_t>(n);
  }
}

}  // namespace

bool isGzipPath(const std::filesystem::path& path) {
  return path.extension() == ".gz";
}

std::string readFile(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  VLN_CHECK_IO(in.good(), "readFile(): cannot open '", file.string(),
               "': ", errnoText(errno));
  std::ostringstream contents;
  contents << in.rdbuf();
  VLN_CHECK_IO(!in.bad(), "readFile(): I/O error reading '", file.string(),
               "'");
  std::string data = contents.str();
  if (hasGzipMagic(data)) return gzipDecompress(data, file.string());
  return data;
}

std::string gzipCompress(std::string_view data, int level) {
  z_stream stream{};
  // 15 window bits + 16 selects the gzip container
  VLN_ASSERT(deflateInit2(&stream, level, Z_DEFLATED, 15 + 16, 8,
                          Z_DEFAULT_STRATEGY) == Z_OK);
  std::string out;
  out.resize(deflateBound(&stream, data.size()) + 32);
  stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  stream.avail_in = static_cast<uInt>(data.size());
  stream.next_out = reinterpret_cast<Bytef*>(out.data());
  stream.avail_out = static_cast<uInt>(out.size());
  int rc = deflate(&stream, Z_FINISH);
  VLN_ASSERT(rc == Z_STREAM_END);
  out.resize(stream.total_out);
  deflateEnd(&stream);
  return out;
}

std::string gzipDecompress(std::string_view data, std::string_view name) {
  z_stream stream{};
  // 15 + 32: auto-detect zlib or gzip header
  VLN_ASSERT(inflateInit2(&stream, 15 + 32) == Z_OK);
  stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  stream.avail_in = static_cast<uInt>(data.size());
  std::string out;
  char buffer[1 << 16];
  int rc = Z_OK;
  while (true) {
    stream.next_out = reinterpret_cast<Bytef*>(buffer);
    stream.avail_out = sizeof(buffer);
    rc = inflate(&stream, Z_NO_FLUSH);
    out.append(buffer, sizeof(buffer) - stream.avail_out);
    if (rc == Z_STREAM_END) {
      // concatenated gzip members are legal; continue with the next one
      if (stream.avail_in > 0 &&
          hasGzipMagic({reinterpret_cast<const char*>(stream.next_in),
                        stream.avail_in})) {
        inflateReset(&stream);
        continue;
      }
      break;
    }
    if (rc != Z_OK) break;
    if (stream.avail_in == 0 && stream.avail_out != 0) {
      rc = Z_BUF_ERROR;  // input ended before the stream did
      break;
    }
  }
  std::string message = stream.msg ? stream.msg : "";
  inflateEnd(&stream);
  if (rc == Z_BUF_ERROR)
    throw std::runtime_error("readFile(): '" + std::string(name) +
                             "' is a truncated gzip stream");
  if (rc != Z_STREAM_END)
    throw std::runtime_error("readFile(): '" + std::string(name) +
                             "' is a corrupt gzip stream: " + message);
  return out;
}

void syncDirectory(const std::filesystem::path& dir) {
  int fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (fd < 0) return;  // best effort: some filesystems refuse directory fds
  ::fsync(fd);
  ::close(fd);
}

void writeFileAtomic(const std::filesystem::path& file,
                     std::string_view contents) {
  static std::atomic<uint64_t> counter{0};
  std::filesystem::path dir = file.parent_path();
  if (!dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    VLN_CHECK_IO(!ec, "writeFileAtomic(): cannot create directory '",
                 dir.string(), "': ", ec.message());
  }
  std::string payload;
  if (isGzipPath(file)) payload = gzipCompress(contents);
  std::string_view bytes =
      isGzipPath(file) ? std::string_view(payload) : contents;

  std::filesystem::path temp = file;
  temp += ".tmp." + std::to_string(::getpid()) + "." +
          std::to_string(counter.fetch_add(1));
  int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  VLN_CHECK_IO(fd >= 0, "writeFileAtomic(): cannot create '", temp.string(),
               "': ", errnoText(errno));
  try {
    writeAll(fd, bytes, file.string());
    VLN_CHECK_IO(::fsync(fd) == 0, "writeFileAtomic(): fsync failed for '",
                 file.string(), "': ", errnoText(errno));
  } catch (...) {
    ::close(fd);
    ::unlink(temp.c_str());
    throw;
  }
  ::close(fd);
  if (::rename(temp.c_str(), file.c_str()) != 0) {
    int err = errno;
    ::unlink(temp.c_str());
    throw std::runtime_error("writeFileAtomic(): cannot rename onto '" +
                             file.string() + "': " + errnoText(err));
  }
  syncDirectory(dir);
}

void writeFileUnsynced(const std::filesystem::path& file,
                       std::string_view contents) {
  const std::filesystem::path dir = file.parent_path();
  if (!dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    VLN_CHECK_IO(!ec, "writeFileUnsynced(): cannot create directory '",
                 dir.string(), "': ", ec.message());
  }
  const int fd =
      ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  VLN_CHECK_IO(fd >= 0, "writeFileUnsynced(): cannot create '", file.string(),
               "': ", errnoText(errno));
  try {
    writeAll(fd, contents, file.string());
  } catch (...) {
    ::close(fd);
    throw;
  }
  VLN_CHECK_IO(::close(fd) == 0, "writeFileUnsynced(): cannot close '",
               file.string(), "': ", errnoText(errno));
}

void syncFileSystem(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  VLN_CHECK_IO(fd >= 0, "syncFileSystem(): cannot open '", path.string(),
               "': ", errnoText(errno));
  const int status = ::syncfs(fd);
  const int err = errno;
  ::close(fd);
  VLN_CHECK_IO(status == 0, "syncFileSystem(): syncfs failed for '",
               path.string(), "': ", errnoText(err));
}

namespace {

// The pid of a writeFileAtomic() temporary name, or 0 when `name` is not one.
pid_t temporaryOwner(const std::string& name) {
  const size_t tag = name.rfind(".tmp.");
  if (tag == std::string::npos || tag == 0) return 0;
  const std::string rest = name.substr(tag + 5);  // "<pid>.<n>"
  const size_t dot = rest.find('.');
  if (dot == std::string::npos || dot == 0 || dot + 1 == rest.size()) return 0;
  const auto digits = [](std::string_view s) {
    return std::all_of(s.begin(), s.end(),
                       [](char c) { return c >= '0' && c <= '9'; });
  };
  const std::string pid = rest.substr(0, dot);
  if (!digits(pid) || !digits(rest.substr(dot + 1)) || pid.size() > 9) return 0;
  return static_cast<pid_t>(std::stol(pid));
}

}  // namespace

std::vector<std::filesystem::path> removeStaleTemporaries(
    const std::filesystem::path& dir) {
  std::vector<std::filesystem::path> removed;
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return removed;
  for (auto it = std::filesystem::recursive_directory_iterator(dir, ec);
       !ec && it != std::filesystem::recursive_directory_iterator();
       it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    const pid_t owner = temporaryOwner(it->path().filename().string());
    // a live owner (ESRCH tells a dead one) may be about to rename it
    if (owner <= 0 || (::kill(owner, 0) == 0 || errno != ESRCH)) continue;
    removed.push_back(it->path());
  }
  VLN_CHECK_IO(!ec, "removeStaleTemporaries(): cannot list '", dir.string(),
               "': ", ec.message());
  for (const auto& path : removed) {
    std::filesystem::remove(path, ec);
    VLN_CHECK_IO(!ec, "removeStaleTemporaries(): cannot remove '",
                 path.string(), "': ", ec.message());
  }
  return removed;
}

}  // namespace vln::common
