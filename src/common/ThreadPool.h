#pragma once
// A fixed pool of worker threads for data-parallel loops.

#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace vln::common {

/// Runs parallelFor() loops on `threads` persistent workers (the calling
/// thread also works). Not re-entrant: one loop at a time per pool.
class ThreadPool {
 public:
  /// `threads` >= 1 counts the calling thread, so 1 means no extra threads.
  explicit ThreadPool(int threads);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  /// Calls fn(i) for i in [0, count) across the pool and waits. Each index
  /// runs exactly once; the first exception thrown by fn is rethrown here
  /// after all started calls finished.
  void parallelFor(size_t count, const std::function<void(size_t)>& fn);

  /// Threads including the caller.
  int size() const { return static_cast<int>(workers_.size()) + 1; }

 private:
  void workerLoop();
  void runIndices();

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable finished_;
  const std::function<void(size_t)>* task_ = nullptr;
  size_t count_ = 0;
  size_t next_ = 0;
  size_t done_ = 0;
  int busy_ = 0;
  uint64_t generation_ = 0;
  bool stopping_ = false;
  std::exception_ptr error_;
};

}  // namespace vln::common
