#include "common/ThreadPool.h"

#include "common/Check.h"

namespace vln::common {

ThreadPool::ThreadPool(int threads) {
  VLN_CHECK_ARG(threads >= 1, "ThreadPool: threads must be >= 1, got ",
                threads);
  for (int i = 1; i < threads; ++i)
    workers_.emplace_back([this] { workerLoop(); });
}

ThreadPool::~ThreadPool() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  for (auto& worker : workers_) worker.join();
}

// claims indices until the current loop is exhausted
void ThreadPool::runIndices() {
  std::unique_lock lock(mutex_);
  while (task_ != nullptr && next_ < count_) {
    size_t index = next_++;
    const auto* task = task_;
    ++busy_;
    lock.unlock();
    try {
      (*task)(index);
    } catch (...) {
      std::lock_guard errorLock(mutex_);
      if (!error_) error_ = std::current_exception();
    }
    lock.lock();
    --busy_;
    ++done_;
    if (done_ == count_) finished_.notify_all();
  }
}

void ThreadPool::workerLoop() {
  uint64_t seen = 0;
  while (true) {
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [&] { return stopping_ || generation_ != seen; });
      if (stopping_) return;
      seen = generation_;
    }
    runIndices();
  }
}

void ThreadPool::parallelFor(size_t count,
                             const std::function<void(size_t)>& fn) {
  if (count == 0) return;
  {
    std::lock_guard lock(mutex_);
    VLN_ASSERT(task_ == nullptr);
    task_ = &fn;
    count_ = count;
    next_ = 0;
    done_ = 0;
    error_ = nullptr;
    ++generation_;
  }
  wake_.notify_all();
  runIndices();
  std::exception_ptr error;
  {
    std::unique_lock lock(mutex_);
    finished_.wait(lock, [&] { return done_ == count_; });
    task_ = nullptr;
    error = error_;
    error_ = nullptr;
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace vln::common
