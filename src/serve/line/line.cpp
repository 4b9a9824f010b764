#include "line/line.hpp"

#include <sys/prctl.h>

#include <fmt/format.h>

namespace lec6::serve {

Line::Line(LineOptions options, std::function<Wire()> open, const Clock& clock)
    : options_(std::move(options)),
      open_(std::move(open)),
      clock_(clock),
      scheduler_(options_.scheduler, clock.now()) {
  describe_ = options_.port;
  try {
    wire_ = open_();
    describe_ = wire_.master->describe();
  } catch (const std::exception& e) {
    // Serve anyway: the other lines work, and this one reopens by itself.
    scheduler_.line_down(fmt::format("{}: {}", options_.port, e.what()), clock_.now());
    next_reopen_ = clock_.now() + options_.reopen_interval;
  }
}

Line::~Line() {
  stop();
}

void Line::start() {
  std::lock_guard lock(mutex_);
  if (thread_.joinable() || stopping_) return;
  thread_ = std::thread([this] { loop(); });
}

void Line::begin_stop() {
  std::vector<PendingCompletion> done;
  {
    std::lock_guard lock(mutex_);
    scheduler_.begin_shutdown(clock_.now());
    done = scheduler_.take_completions();
  }
  wake_.notify_all();
  deliver(std::move(done), {});
}

void Line::stop() {
  begin_stop();
  {
    // The stops still queued go out while the line works (a dead line's
    // stops fail below: they cannot reach anything).
    std::unique_lock lock(mutex_);
    if (thread_.joinable()) {
      const auto until =
          std::chrono::steady_clock::now() +
          std::chrono::duration_cast<std::chrono::steady_clock::duration>(options_.stop_drain);
      drained_.wait_until(lock, until,
                          [this] { return scheduler_.drained() || scheduler_.is_line_down(); });
    }
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  std::vector<PendingCompletion> done;
  {
    std::lock_guard lock(mutex_);
    scheduler_.shut_down(clock_.now());
    done = scheduler_.take_completions();
  }
  deliver(std::move(done), {});
}

JobId Line::submit(Job job) {
  std::vector<PendingCompletion> done;
  JobId id;
  {
    std::lock_guard lock(mutex_);
    id = scheduler_.submit(std::move(job), clock_.now());
    done = scheduler_.take_completions();
  }
  wake_.notify_all();
  deliver(std::move(done), {});  // a cache hit or a refusal: answered on the caller's thread
  return id;
}

bool Line::cancel(JobId id) {
  std::vector<PendingCompletion> done;
  bool cancelled;
  {
    std::lock_guard lock(mutex_);
    cancelled = scheduler_.cancel(id, clock_.now());
    done = scheduler_.take_completions();
  }
  deliver(std::move(done), {});
  return cancelled;
}

void Line::post(std::function<void()> task) {
  {
    std::lock_guard lock(mutex_);
    tasks_.push_back(std::move(task));
  }
  wake_.notify_all();
}

void Line::post_twin(std::function<void(sim::Bus*, TimePoint now)> task) {
  post([this, task = std::move(task)] { task(wire_.twin, clock_.now()); });
}

void Line::add_observer(TelemetryObserver observer) {
  std::lock_guard lock(mutex_);
  observers_.push_back(std::move(observer));
}

void Line::deliver(std::vector<PendingCompletion> completions, std::vector<TelemetryEvent> events) {
  for (auto& c : completions) c.done(c.result);
  if (events.empty()) return;
  std::vector<TelemetryObserver> observers;
  std::vector<AxisSnapshot> snapshots;
  {
    std::lock_guard lock(mutex_);
    observers = observers_;
    for (const auto& e : events) snapshots.push_back(scheduler_.cache().snapshot(e.id));
  }
  for (std::size_t i = 0; i < events.size(); ++i) {
    for (const auto& o : observers) o(events[i], snapshots[i]);
  }
}

void Line::run_tasks() {
  std::deque<std::function<void()>> tasks;
  {
    std::lock_guard lock(mutex_);
    tasks.swap(tasks_);
  }
  for (auto& t : tasks) t();
}

// Called with the line down and the reopen time reached; outside the lock.
bool Line::try_reopen() {
  try {
    Wire wire = open_();
    std::lock_guard lock(mutex_);
    wire_ = std::move(wire);
    describe_ = wire_.master->describe();
    scheduler_.line_up(clock_.now());
    return true;
  } catch (const std::exception& e) {
    std::lock_guard lock(mutex_);
    next_reopen_ = clock_.now() + options_.reopen_interval;
    scheduler_.line_down(fmt::format("{}: {}", options_.port, e.what()), clock_.now());
    return false;
  }
}

bool Line::run_once() {
  run_tasks();
  std::optional<Dispatch> d;
  bool reopen = false;
  // Reads next() answered from the cache when their turn came (two clients
  // that asked for the same block): delivered now, not behind the exchange
  // below or, with nothing for the wire, never
  // (Line.AReadAnsweredFromTheCacheAtItsTurnIsDeliveredAtOnce).
  std::vector<PendingCompletion> answered;
  {
    std::lock_guard lock(mutex_);
    if (scheduler_.is_line_down()) {
      reopen = !stopping_ && clock_.now() >= next_reopen_;
    } else {
      d = scheduler_.next(clock_.now());
      answered = scheduler_.take_completions();
    }
  }
  deliver(std::move(answered), {});
  if (reopen) return try_reopen();
  if (!d) return false;
  // Only this thread touches the wire; the lock is free while it works.
  const TimePoint start = clock_.now();
  std::optional<modbus::ResponseFrame> reply;
  std::optional<client::TransportError> error;
  try {
    reply = wire_.master->exchange(d->frame);
  } catch (const client::TransportError& e) {
    error = e;
  } catch (const std::exception& e) {
    error = client::TransportError(client::TransportErrorKind::Port, e.what());
  }
  std::vector<PendingCompletion> done;
  std::vector<TelemetryEvent> events;
  {
    std::lock_guard lock(mutex_);
    const TimePoint end = clock_.now();
    if (reply) {
      scheduler_.completed(*reply, start, end);
    } else {
      scheduler_.failed(*error, start, end);
      if (scheduler_.is_line_down()) {
        wire_ = Wire{};
        next_reopen_ = end + options_.reopen_interval;
      }
    }
    done = scheduler_.take_completions();
    events = scheduler_.take_events();
    if (scheduler_.drained()) drained_.notify_all();
  }
  deliver(std::move(done), std::move(events));
  return true;
}

void Line::loop() {
  // Wake at the instant asked (the end of Ts before a query), not up to the
  // default 50 µs later: on a saturated line that slack is lost line time.
  ::prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  for (;;) {
    {
      std::lock_guard lock(mutex_);
      if (stopping_) return;  // after the transaction that was on the wire
    }
    if (run_once()) continue;
    std::unique_lock lock(mutex_);
    if (stopping_) return;
    if (!tasks_.empty()) continue;
    std::optional<TimePoint> at =
        scheduler_.is_line_down() ? std::optional(next_reopen_) : scheduler_.wake_at();
    // Anything ready is picked up at once: wait only when nothing is (a
    // stop that waits for its backoff wakes us at wake_at()).
    if (scheduler_.ready(clock_.now())) continue;
    if (at) {
      wake_.wait_until(lock, *at);
    } else {
      wake_.wait(lock);
    }
  }
}

std::optional<TimePoint> Line::wake_at() const {
  std::lock_guard lock(mutex_);
  if (scheduler_.is_line_down()) return next_reopen_;
  return scheduler_.wake_at();
}

std::string Line::describe() const {
  std::lock_guard lock(mutex_);
  return describe_;
}

bool Line::is_down() const {
  std::lock_guard lock(mutex_);
  return scheduler_.is_line_down();
}

std::string Line::down_reason() const {
  std::lock_guard lock(mutex_);
  return scheduler_.down_reason();
}

LineStatsSnapshot Line::stats() const {
  std::lock_guard lock(mutex_);
  return scheduler_.stats(clock_.now());
}

DeviceCounters Line::device_counters(uint8_t id) const {
  std::lock_guard lock(mutex_);
  return scheduler_.device_counters(id);
}

DeviceHealth Line::health(uint8_t id) const {
  std::lock_guard lock(mutex_);
  return scheduler_.health(id);
}

bool Line::stopping() const {
  std::lock_guard lock(mutex_);
  return scheduler_.shutting_down();
}

std::optional<TimePoint> Line::last_hard_stop(uint8_t id) const {
  std::lock_guard lock(mutex_);
  return scheduler_.last_hard_stop(id);
}

AxisSnapshot Line::snapshot(uint8_t id) const {
  std::lock_guard lock(mutex_);
  return scheduler_.cache().snapshot(id);
}

std::optional<Duration> Line::age(uint8_t id, Block block) const {
  std::lock_guard lock(mutex_);
  return scheduler_.cache().age(id, block, clock_.now());
}

}  // namespace lec6::serve
