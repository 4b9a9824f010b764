#include "query_worker.hpp"

namespace lec6::serve::history {

QueryWorker::QueryWorker(std::size_t capacity) : capacity_(capacity) {
  thread_ = std::thread([this] { loop(); });
}

QueryWorker::~QueryWorker() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

bool QueryWorker::post(std::function<void()> job) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || jobs_.size() >= capacity_) return false;
    jobs_.push_back(std::move(job));
  }
  wake_.notify_one();
  return true;
}

void QueryWorker::loop() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stopping_ || !jobs_.empty(); });
    if (jobs_.empty()) return;  // stopping, and nothing left
    auto job = std::move(jobs_.front());
    jobs_.pop_front();
    lock.unlock();
    try {
      job();
    } catch (...) {  // a job answers its own errors; nothing may end this thread
    }
    lock.lock();
  }
}

}  // namespace lec6::serve::history
