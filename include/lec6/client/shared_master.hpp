#pragma once
// One line shared by threads. A Master serves one thread at a time (master.hpp);
// a SharedMaster wraps one so that any number of threads, each with its own
// Client (and Actuator), can use it: every exchange takes the line in turn,
// first come first served (a ticket lock), so a move polling in one thread and
// status reads in another interleave transaction by transaction instead of one
// starving the other.
//
//   auto port = lec6::twin::open_port(spec);
//   lec6::client::SharedMaster line(port->master());
//   // in each thread:
//   lec6::client::Client c(line, {.id = 2});
//   lec6::client::Actuator axis(c);
//
// The Python module's Bus is one; `lec serve` has its own scheduler instead
// (priorities, a telemetry cache).
//
// Thread safety: every member may be called from any thread. A Client or
// Actuator on it is still one thread's (client.hpp); make one per thread, they
// cost a few words and no I/O. idle_until() (WaitOptions::poll_interval) waits
// without holding the line.
//
// Lifetime: the first constructor keeps a reference to `inner`, which must
// outlive the SharedMaster. The second shares an `owner` that keeps `inner` (and
// what it talks through) alive until close(); clock() is then `clock`, which
// must outlive the SharedMaster, since the inner master's goes with the owner.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "lec6/client/master.hpp"

namespace lec6::client {

class SharedMaster final : public Master {
 public:
  explicit SharedMaster(Master& inner);
  SharedMaster(std::shared_ptr<void> owner, Master& inner, const Clock& clock);
  SharedMaster(const SharedMaster&) = delete;
  SharedMaster& operator=(const SharedMaster&) = delete;

  // Waits for the line's turn, then inner.exchange(). After close() it throws
  // TransportError (Port).
  modbus::ResponseFrame exchange(const modbus::RequestFrame& frame) override;
  const Clock& clock() const override { return clock_; }
  std::string describe() const override { return description_; }
  // The inner master's counters as of its last exchange: never waits for the
  // exchange in progress.
  LinkStats stats() const override;
  Duration last_round_trip() const override;
  const modbus::LineTiming& line_timing() const override { return timing_; }

  // Waits for the exchange in progress, then lets go of the inner master (and
  // frees the owner); later exchanges throw TransportError (Port).
  void close();
  bool closed() const;

  // Runs `f` holding the line, e.g. to touch an in-process twin between
  // exchanges. `f` gets the owner (null once closed, or when there is none).
  template <typename F>
  auto with_line(F&& f) {
    Turn turn(*this);
    return f(owner_.get());
  }

  // Threads waiting for the line (not counting the one holding it).
  std::size_t waiting() const;

  // Masters leave retries and exception replies to the Client (master.hpp):
  // each thread's Client may add its own here, and totals() has everything.
  void count(uint64_t retries, uint64_t exceptions);
  LinkStats totals() const;

 private:
  // The line for one holder, in arrival order.
  class Turn {
   public:
    explicit Turn(const SharedMaster& line);
    ~Turn();
    Turn(const Turn&) = delete;
    Turn& operator=(const Turn&) = delete;

   private:
    const SharedMaster& line_;
  };

  mutable std::mutex mutex_;
  mutable std::condition_variable turn_;
  mutable uint64_t next_ticket_ = 0;
  mutable uint64_t serving_ = 0;

  std::shared_ptr<void> owner_;
  Master* inner_;
  const Clock& clock_;
  std::string description_;
  modbus::LineTiming timing_;
  mutable std::mutex stats_mutex_;
  LinkStats stats_;
  Duration last_round_trip_{};
  std::atomic<uint64_t> retries_{0};
  std::atomic<uint64_t> exceptions_{0};
};

}  // namespace lec6::client
