#pragma once
// The history's queries run here, on a thread of their own (issue 32): the
// daemon's I/O thread carries Modbus TCP, HTTP (stops included) and the event
// streams, and a query over a large history must not hold them. One thread,
// a bounded queue: beyond `capacity` waiting queries, post() says no and the
// caller answers 503. The destructor runs what is queued, then joins.
//
// Thread safety: post() from any thread.

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>

namespace lec6::serve::history {

class QueryWorker {
 public:
  explicit QueryWorker(std::size_t capacity = 64);
  ~QueryWorker();
  QueryWorker(const QueryWorker&) = delete;
  QueryWorker& operator=(const QueryWorker&) = delete;

  bool post(std::function<void()> job);

 private:
  void loop();

  std::size_t capacity_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> jobs_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace lec6::serve::history
