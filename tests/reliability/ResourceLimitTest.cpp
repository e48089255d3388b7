// Checkpoint writes and feature-store commits when the disk says no: under a
// file-size limit (RLIMIT_FSIZE, EFBIG; SIGXFSZ ignored as common::runMain
// does) and on a full filesystem (ENOSPC, a 512 KiB tmpfs mounted in a
// private mount namespace). Each scenario runs in a forked child, because
// the limit and the mount belong to that process; the child reports what it
// saw as text lines "FAIL <what>" / "NOTE <what>" on a pipe, and the parent
// turns them into test results. Expected: a clear std::runtime_error naming
// the file (or store directory), the previous checkpoint intact and
// loadable, every committed episode readable, no temporary file left, and
// writing works again once there is room.

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sched.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <iostream>
#include <functional>
#include <sstream>

#include "support/TestPaths.h"
#include "train/Checkpoint.h"
#include "train/FeatureStore.h"

namespace vln::reliability {
namespace {

namespace fs = std::filesystem;

// what a child found; empty fails means every check held
struct Report {
  std::vector<std::string> fails;
  std::vector<std::string> notes;
  bool skipped = false;
};

class Reporter {
 public:
  explicit Reporter(int fd) : fd_(fd) {}
  void check(bool ok, const std::string& what) {
    if (!ok) line("FAIL " + what);
  }
  void note(const std::string& what) { line("NOTE " + what); }
  void skip(const std::string& why) { line("SKIP " + why); }

 private:
  void line(std::string text) {
    for (char& c : text)
      if (c == '\n') c = ' ';
    text += '\n';
    (void)!::write(fd_, text.data(), text.size());
  }
  int fd_;
};

// runs `body` in a forked child and collects its report
Report inChild(const std::function<void(Reporter&)>& body) {
  int fds[2];
  EXPECT_EQ(::pipe(fds), 0);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    Reporter reporter(fds[1]);
    try {
      body(reporter);
    } catch (const std::exception& e) {
      reporter.check(false, std::string("unexpected exception: ") + e.what());
    }
    ::close(fds[1]);
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string text;
  char buffer[4096];
  ssize_t n;
  while ((n = ::read(fds[0], buffer, sizeof(buffer))) > 0) text.append(buffer, static_cast<size_t>(n));
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  Report report;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    report.fails.push_back("child died (status " + std::to_string(status) + ")");
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.starts_with("FAIL ")) report.fails.push_back(line.substr(5));
    if (line.starts_with("NOTE ")) report.notes.push_back(line.substr(5));
    if (line.starts_with("SKIP ")) {
      report.skipped = true;
      report.notes.push_back(line.substr(5));
    }
  }
  return report;
}

train::Checkpoint checkpointOfBytes(int64_t floats, float value) {
  train::Checkpoint c;
  c.config_yaml = "trainer:\n  seed: 7\n";
  c.policy = {{"w", torch::full({floats}, value)}, {"b", torch::arange(3, torch::kFloat32)}};
  c.optimizer_state = std::string(64, 'o');
  c.progress.checkpoint_index = 0;
  c.progress.stage = "dagger";
  c.rng_state = "rng";
  return c;
}

bool sameCheckpoint(const train::Checkpoint& a, const train::Checkpoint& b) {
  if (a.config_yaml != b.config_yaml || a.policy.size() != b.policy.size() ||
      a.optimizer_state != b.optimizer_state || a.rng_state != b.rng_state)
    return false;
  for (size_t i = 0; i < a.policy.size(); ++i)
    if (a.policy[i].first != b.policy[i].first ||
        !torch::equal(a.policy[i].second, b.policy[i].second))
      return false;
  return true;
}

std::vector<std::string> leftovers(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().find(".tmp.") != std::string::npos)
      names.push_back(e.path().filename().string());
  return names;
}

// A small checkpoint fits, a large one does not: the failure names the file
// and keeps the small one; a second small one then fits again.
void checkpointScenario(Reporter& r, const fs::path& dir) {
  const fs::path file = dir / train::checkpointFileName(0);
  const train::Checkpoint small = checkpointOfBytes(256, 1.0f);
  train::saveCheckpoint(file, small);
  try {
    train::saveCheckpoint(file, checkpointOfBytes(1 << 20, 2.0f));  // 4 MiB of floats
    r.check(false, "a 4 MiB checkpoint was written past the limit");
  } catch (const std::runtime_error& e) {
    const std::string message = e.what();
    r.note("checkpoint error: " + message);
    r.check(message.find(file.string()) != std::string::npos,
            "the error does not name the file: " + message);
  }
  r.check(sameCheckpoint(train::loadCheckpoint(file), small),
          "the previous checkpoint changed or does not load");
  const auto temps = leftovers(dir);
  r.check(temps.empty(), "temporary files left behind: " + (temps.empty() ? "" : temps[0]));
  const fs::path next = dir / train::checkpointFileName(1);
  train::Checkpoint again = checkpointOfBytes(256, 3.0f);
  again.progress.checkpoint_index = 1;
  train::saveCheckpoint(next, again);
  r.check(sameCheckpoint(train::loadCheckpoint(next), again),
          "a small checkpoint after the failure does not load back");
}

train::StoredEpisode episode(int64_t id, int32_t slot, int64_t steps) {
  train::StoredEpisode e;
  e.key.episode_id = id;
  e.key.iteration = 0;
  e.key.slot = slot;
  e.tokens = {4, 5, 6};
  e.prev_actions.assign(static_cast<size_t>(steps), 1);
  e.oracle_actions.assign(static_cast<size_t>(steps), 2);
  e.progress.assign(static_cast<size_t>(steps), 0.5f);
  e.rgb = torch::full({steps, 4, 4, 4}, static_cast<float>(id));
  return e;
}

// Three small episodes commit; one large one fails naming the store
// directory, the cause (`cause`: the limit or the full disk) and what
// survived; the store reopens with the three episodes, each passing its CRC
// check.
void storeScenario(Reporter& r, const fs::path& dir, const std::string& cause) {
  train::StoreLayout layout;
  layout.rgb_shape = {4, 4, 4};
  layout.fp16 = false;
  layout.config_hash = "limits";
  const fs::path storeDir = dir / "store";
  {
    train::FeatureStore store(storeDir, layout, /*maxGib=*/0.05);
    for (int i = 0; i < 3; ++i) store.append(episode(100 + i, i, 5));
    try {
      store.append(episode(200, 3, 20000));  // 5 MiB of features
      r.check(false, "a 5 MiB episode was committed past the limit");
    } catch (const std::runtime_error& e) {
      const std::string message = e.what();
      r.note("store error: " + message);
      r.check(message.find(storeDir.string()) != std::string::npos,
              "the error does not name the store: " + message);
      r.check(message.find(cause) != std::string::npos,
              "the error does not say '" + cause + "': " + message);
      r.check(message.find("3 episodes committed before it are intact") !=
                  std::string::npos,
              "the error does not say what survived: " + message);
    }
    r.check(store.size() == 3, "the store counts the failed episode");
    // whether this handle can still append (LMDB may refuse after a failed
    // commit) is reported, not required: a restarted trainer reopens
    try {
      store.append(episode(103, 3, 5));
      r.note("the same handle appended again after the failure");
    } catch (const std::exception& e) {
      r.note(std::string("the same handle refuses further appends: ") + e.what());
    }
  }
  auto reopened = train::FeatureStore::openExisting(storeDir);
  r.check(reopened->size() == 3 || reopened->size() == 4,
          "the reopened store has " + std::to_string(reopened->size()) + " episodes");
  for (int64_t i = 0; i < reopened->size(); ++i) {
    const train::StoredEpisode e = reopened->read(i);
    r.check(e.key.episode_id == 100 + i && e.length() == 5 &&
                torch::equal(e.rgb.to(torch::kFloat32),
                             torch::full({5, 4, 4, 4}, static_cast<float>(100 + i))),
            "episode " + std::to_string(i) + " came back different");
  }
}

void limitFileSize(Reporter& r, rlim_t bytes) {
  std::signal(SIGXFSZ, SIG_IGN);  // as common::runMain
  rlimit limit{bytes, bytes};
  r.check(::setrlimit(RLIMIT_FSIZE, &limit) == 0, "setrlimit(RLIMIT_FSIZE) failed");
}

// mounts a `kib` KiB tmpfs on `dir` in a private mount namespace (a user
// namespace first when not root); false with a reason when the kernel or
// the container refuses
bool mountTinyTmpfs(const fs::path& dir, int kib, std::string* why) {
  if (::geteuid() != 0 && ::unshare(CLONE_NEWUSER) != 0) {
    *why = std::string("unshare(CLONE_NEWUSER): ") + std::strerror(errno);
    return false;
  }
  if (::unshare(CLONE_NEWNS) != 0) {
    *why = std::string("unshare(CLONE_NEWNS): ") + std::strerror(errno);
    return false;
  }
  // keep the mount out of the parent's namespace
  if (::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0) {
    *why = std::string("making / private: ") + std::strerror(errno);
    return false;
  }
  const std::string options = "size=" + std::to_string(kib) + "k";
  if (::mount("tmpfs", dir.c_str(), "tmpfs", 0, options.c_str()) != 0) {
    *why = std::string("mount tmpfs: ") + std::strerror(errno);
    return false;
  }
  return true;
}

void expectClean(const Report& report) {
  for (const auto& note : report.notes) std::cout << "  note: " << note << "\n";
  EXPECT_TRUE(report.fails.empty()) << ::testing::PrintToString(report.fails);
}

class ResourceLimitTest : public ::testing::Test {
 protected:
  void SetUp() override { torch::set_num_threads(1); }  // fork-safe LibTorch
  vln::test::TempDir dir_;
};

TEST_F(ResourceLimitTest, CheckpointUnderFileSizeLimit) {
  const Report report = inChild([&](Reporter& r) {
    limitFileSize(r, 256 * 1024);
    checkpointScenario(r, dir_.path());
  });
  expectClean(report);
  // and the parent, without the limit, reads what the child kept
  EXPECT_TRUE(sameCheckpoint(train::loadCheckpoint(dir_ / "ckpt.0.pth"), checkpointOfBytes(256, 1.0f)));
}

TEST_F(ResourceLimitTest, StoreCommitUnderFileSizeLimit) {
  const Report report = inChild([&](Reporter& r) {
    limitFileSize(r, 1024 * 1024);
    storeScenario(r, dir_.path(), "the file size limit, ulimit -f, is 1048576 bytes");
  });
  expectClean(report);
  EXPECT_GE(train::FeatureStore::openExisting(dir_ / "store")->size(), 3);
}

TEST_F(ResourceLimitTest, CheckpointAndStoreOnAFullDisk) {
  fs::create_directories(dir_ / "tiny");
  const Report report = inChild([&](Reporter& r) {
    std::string why;
    if (!mountTinyTmpfs(dir_ / "tiny", 1024, &why)) {
      r.skip("cannot mount a tmpfs here: " + why);
      return;
    }
    checkpointScenario(r, dir_ / "tiny");
    // start the store scenario on an emptied disk
    fs::remove_all(dir_ / "tiny" / "ckpt.0.pth");
    fs::remove_all(dir_ / "tiny" / "ckpt.1.pth");
    storeScenario(r, dir_ / "tiny", "the disk is full");
  });
  if (report.skipped) GTEST_SKIP() << ::testing::PrintToString(report.notes);
  expectClean(report);
}

}  // namespace
}  // namespace vln::reliability
