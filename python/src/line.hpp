#pragma once
// One bus shared by Python threads. A client::Master serves one thread at a
// time; SharedLine wraps it so that any number of threads (and Axis objects)
// can use it: each exchange takes the line in turn, first come first served,
// so a move polling in one thread and status() calls in another interleave
// transaction by transaction instead of one starving the other.

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>

#include "lec6/client/master.hpp"

namespace lec6::python {

class SharedLine final : public client::Master {
 public:
  // `owner` keeps `inner` (and what it talks through) alive until close().
  SharedLine(std::shared_ptr<void> owner, client::Master& inner);

  modbus::ResponseFrame exchange(const modbus::RequestFrame& frame) override;
  // Steady clocks all read the same time; this one stays valid after close().
  const Clock& clock() const override { return clock_; }
  std::string describe() const override { return description_; }
  client::LinkStats stats() const override;
  Duration last_round_trip() const override;
  const modbus::LineTiming& line_timing() const override { return timing_; }

  // Waits for the exchange in progress, then releases the port; later
  // exchanges throw TransportError (port).
  void close();
  bool closed() const;

  // Runs `f` holding the line, e.g. to touch an in-process twin between
  // exchanges. `f` gets the owner (null once closed).
  template <typename F>
  auto with_line(F&& f) {
    Turn turn(*this);
    return f(owner_.get());
  }

  // Masters leave retries and exception replies to the Client (master.hpp):
  // each call's Client adds its own here, and totals() has everything.
  void count(uint64_t retries, uint64_t exceptions);
  client::LinkStats totals() const;

 private:
  // The line for one holder, in arrival order (a ticket lock).
  class Turn {
   public:
    explicit Turn(const SharedLine& line);
    ~Turn();
    Turn(const Turn&) = delete;
    Turn& operator=(const Turn&) = delete;

   private:
    const SharedLine& line_;
  };

  mutable std::mutex mutex_;
  mutable std::condition_variable turn_;
  mutable uint64_t next_ticket_ = 0;
  mutable uint64_t serving_ = 0;

  std::shared_ptr<void> owner_;
  client::Master* inner_;
  SteadyClock clock_;
  std::string description_;
  modbus::LineTiming timing_;
  // The inner master's counters as of its last exchange, so that stats()
  // never waits for a transaction in progress.
  mutable std::mutex stats_mutex_;
  client::LinkStats stats_;
  Duration last_round_trip_{};
  std::atomic<uint64_t> retries_{0};
  std::atomic<uint64_t> exceptions_{0};
};

}  // namespace lec6::python
