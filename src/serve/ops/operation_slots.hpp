#pragma once
// What Operations keeps per axis (private to serve/ops/operations*.cpp): the
// motion under way, the stops still running, an unsettled end, the last
// result.

#include <atomic>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "ops/operations.hpp"

namespace lec6::serve {

struct Operations::Running {
  Op op = Op::Move;
  // What refusals and the axis's status call it, when not its op's name: a
  // machine cycle's motion of several axes ("cycle pick-place": run_claimed).
  std::string what;
  std::string source;
  TimePoint since{};
  // When it was accepted, on its line's clock: a stop accepted after that
  // supersedes its starts, however late they reach the line (LineMaster::
  // count_from; a DCMD move raced by a stop 1.4 ms later moved the axis after
  // the stop's "stopped": the move's start came after its reads).
  TimePoint accepted{};
  bool jog_plus = true;
  std::atomic<bool> cancel{false};
  std::atomic<bool> stopped_by_other{false};
  // A stop or reset for this axis (not a hold: a held motion resumes).
  std::atomic<bool> stop_requested{false};
  std::atomic<int64_t> lease_until{0};  // steady ns; 0: no lease
  std::mutex tie_mutex;
  std::function<bool()> tie;  // the stream a jog is tied to has closed
  // Set when it has ended (its result known): what waits for it wakes.
  std::promise<void> ended_promise;
  std::shared_future<void> ended = ended_promise.get_future().share();
  // The stops, holds, resets and servo offs accepted on its axis before it,
  // still running then: it waits for them before anything goes to the line.
  struct Awaited {
    std::shared_future<void> ended;
    Op op;
    std::string source;
  };
  std::vector<Awaited> after;
  // Under Operations::mutex_: it still waits for one of them (since: when it
  // was accepted; once it starts, since is when it started).
  bool waiting = false;
  // "reset (by http 127.0.0.1)": the first of `after` still running.
  std::string waiting_for() const {
    for (const Awaited& a : after) {
      if (a.ended.wait_for(Duration::zero()) != std::future_status::ready)
        return fmt::format("{} (by {})", op_name(a.op), a.source);
    }
    return "";
  }
  // It ended while it waited: nothing of it reached the line (a 5xx then
  // does not leave the axis "may still be moving").
  std::atomic<bool> nothing_sent{false};

  std::string name() const { return what.empty() ? std::string(op_name(op)) : what; }
  bool lease_expired(TimePoint now) const {
    const int64_t until = lease_until.load();
    return until != 0 && now.time_since_epoch().count() > until;
  }
  bool tie_closed() {
    std::lock_guard lock(tie_mutex);
    return tie && tie();
  }
};

// A motion that ended without the daemon knowing the axis stopped (a deadline,
// no answer, the line down): the axis may still be moving, so the slot stays
// taken until a read of the flags taken after that end shows BUSY = 0
// (docs/protocol-decisions.md, "One motion per axis").
struct Operations::Unsettled {
  Op op = Op::Move;
  std::string source;
  std::string why;
  TimePoint ended{};   // on the line's clock
  std::string what{};  // what ran, when not the op (a cycle: Running::what)
  std::string name() const { return what.empty() ? std::string(op_name(op)) : what; }
};

struct Operations::Slot {
  std::shared_ptr<Running> motion;
  // The stops, holds, resets and servo offs running on the axis (not the
  // ended ones).
  std::vector<std::weak_ptr<Running>> stops;
  std::optional<Unsettled> unsettled;
  std::optional<nlohmann::json> last;
};

}  // namespace lec6::serve
