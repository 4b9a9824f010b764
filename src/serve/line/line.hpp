#pragma once
// One RS485 line owned by lec serve: the scheduler (sans-I/O) driven over the
// line's Master, on a thread of its own. The Master (an RtuMaster on a serial
// port, on the in-process twin, or on RTU over TCP) and its timing rules
// stay the only thing that talks to the wire.
//
// Every front-end submits jobs here (Modbus TCP, HTTP, MQTT, operations);
// completions and telemetry events are delivered on the line's thread,
// outside its lock: handlers must be quick (post to an event loop, fulfil a
// promise).
//
// A port that goes away (TransportError Port) takes the line down: queued
// jobs fail, and the line reopens it every `reopen_interval`.
//
// Thread safety: every public member may be called from any thread.

#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "lec6/client/master.hpp"
#include "line/scheduler.hpp"

namespace lec6::sim {
class Bus;
}

namespace lec6::serve {

// What a line talks through. `keep` holds whatever the master needs alive
// (the link, the in-process twin).
struct Wire {
  std::shared_ptr<void> keep;
  std::unique_ptr<client::Master> master;
  sim::Bus* twin = nullptr;  // the in-process twin of a `port: sim` line
};

struct LineOptions {
  std::string name;
  std::string port;  // as configured: "/dev/ttyUSB0", "sim", "rtu+tcp://…"
  SchedulerConfig scheduler;
  Duration reopen_interval = std::chrono::seconds(1);
  // stop(): how long the stops still queued may take to reach the wire.
  Duration stop_drain = std::chrono::seconds(5);
};

using TelemetryObserver = std::function<void(const TelemetryEvent&, const AxisSnapshot&)>;

class Line {
 public:
  // `open` makes the wire (now, and again after the port went away); it
  // throws TransportError / LinkError when the port cannot be opened. The
  // clock is the wire's (a VirtualClock in tests).
  Line(LineOptions options, std::function<Wire()> open, const Clock& clock);
  ~Line();
  Line(const Line&) = delete;
  Line& operator=(const Line&) = delete;

  // Starts the line's thread. Without it, run_once() drives the line (tests).
  void start();
  // Refuses every new job but stops, fails the queued ones but stops
  // (ShuttingDown), sends the stops still queued and those submitted
  // meanwhile (for at most `stop_drain`), then finishes the transaction in
  // flight, fails what is left and joins the thread. An accepted stop is never
  // dropped by a shutdown while the line works (issue 31 rule 4;
  // OperationsStop.TheLineSendsTheStopsQueuedWhenItCloses).
  void stop();
  // The first half of stop(): from now on only stops are taken.
  void begin_stop();

  JobId submit(Job job);
  bool cancel(JobId id);
  // Runs `task` on the line's thread between two transactions (e.g. changes
  // to the in-process twin, which only that thread may touch).
  void post(std::function<void()> task);
  // Runs `task` on the line's thread with its in-process twin (null when the
  // line is not `sim`, or is down).
  void post_twin(std::function<void(sim::Bus*, TimePoint now)> task);
  void add_observer(TelemetryObserver observer);

  // One step without waiting: runs due tasks and at most one transaction.
  // Returns false when there was nothing to do.
  bool run_once();
  // When run_once() will next have something to do without a submit (tests
  // on a virtual clock jump there); nullopt: only a submit.
  std::optional<TimePoint> wake_at() const;

  const LineOptions& options() const noexcept { return options_; }
  const Clock& clock() const noexcept { return clock_; }
  const modbus::LineTiming& timing() const noexcept { return options_.scheduler.timing; }
  std::string describe() const;
  bool is_down() const;
  std::string down_reason() const;
  LineStatsSnapshot stats() const;
  // One controller's counters, without the line's percentiles (held under the
  // line's lock: telemetry views call this per axis and per sample).
  DeviceCounters device_counters(uint8_t id) const;
  DeviceHealth health(uint8_t id) const;
  // lec serve is stopping: the line takes only Emergency jobs (begin_stop).
  bool stopping() const;
  // Scheduler::last_hard_stop, under the line's lock.
  std::optional<TimePoint> last_hard_stop(uint8_t id) const;
  AxisSnapshot snapshot(uint8_t id) const;
  std::optional<Duration> age(uint8_t id, Block block) const;

 private:
  void loop();
  void deliver(std::vector<PendingCompletion> completions, std::vector<TelemetryEvent> events);
  bool try_reopen();
  void run_tasks();

  LineOptions options_;
  std::function<Wire()> open_;
  const Clock& clock_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable drained_;  // stop(): the last stop left
  Scheduler scheduler_;
  Wire wire_;
  std::string describe_;
  TimePoint next_reopen_{};
  std::deque<std::function<void()>> tasks_;
  std::vector<TelemetryObserver> observers_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace lec6::serve
