#pragma once
// What stands behind a Responder and an EventStream: the answer-once
// exchange, and one SSE stream's bounded queue. Sans-I/O: the connection
// (http_connection.cpp) drains the queue when woken.
//
// Thread safety: every member may be called from any thread.

#include <atomic>
#include <cstddef>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "http/http_server.hpp"

namespace lec6::serve::detail {

class StreamState {
 public:
  // `limit` droppable events queued at most; reliable ones up to 4 × limit.
  explicit StreamState(std::size_t limit);

  // The connection's doorbell: called (outside the lock) when there is
  // something new to write or the stream was closed. Set once by the
  // connection before the first push can happen.
  void set_wake(std::function<void()> wake);

  // Queues encoded event bytes; false when closed.
  bool push(std::string bytes, bool droppable);
  // Everything queued, in order, as one buffer (empty when nothing is).
  std::string drain();
  bool empty() const;

  // Marks the stream closed; true if it was open. Wakes the connection so it
  // writes what is queued, closes, and runs the callbacks on its thread.
  bool close();
  bool closed() const;
  void on_close(std::function<void()> callback);
  // Runs the close callbacks once (the connection, after close()).
  void run_close_callbacks();

  std::size_t dropped() const;

 private:
  struct Item {
    std::string bytes;
    bool droppable;
  };
  void wake();

  const std::size_t limit_;
  mutable std::mutex mutex_;
  std::deque<Item> queue_;
  std::size_t dropped_ = 0;
  bool closed_ = false;
  bool callbacks_ran_ = false;
  bool wake_pending_ = false;
  std::function<void()> wake_;
  std::vector<std::function<void()>> callbacks_;
};

// The answer-once half of a Responder.
class Exchange {
 public:
  virtual ~Exchange() = default;
  bool answered() const { return answered_.load(); }
  virtual bool respond(HttpResponse response) = 0;
  virtual EventStream open_stream() = 0;

 protected:
  // True for the first caller only.
  bool claim() { return !answered_.exchange(true); }
  static EventStream stream_of(std::shared_ptr<StreamState> s) { return EventStream(std::move(s)); }
  static Responder responder_of(std::shared_ptr<Exchange> e) { return Responder(std::move(e)); }

 private:
  std::atomic<bool> answered_{false};
};

}  // namespace lec6::serve::detail
