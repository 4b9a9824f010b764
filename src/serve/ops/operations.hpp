#pragma once
// Axis operations inside lec serve: the commands of commands.hpp run by the
// library's Actuator (the manual's sequences and completion logic, unchanged)
// over a LineMaster, one thread per running operation, so a move's polling
// queues on the line at Priority::Completion while other clients go on.
//
// Rules:
//   - one motion (home, move, run-step, jog) per axis at a time; another one
//     is refused with 409 naming what runs and who started it (two clients
//     fighting over one axis is how machines crash). A motion that ended
//     without the axis seen stopped (5xx: deadline, no answer, line down)
//     keeps the axis taken until a read of its flags, taken after that end,
//     shows BUSY = 0;
//   - stop, hold and reset always go, at Priority::Emergency, also while lec
//     serve shuts down (a line sends stops until it closes), and the motion
//     under way then ends as "stopped"; a stop or reset ends a jog too (JOG
//     released). A stop or hold is judged by the axis (client/stop.hpp):
//     200 "stopped at X mm" only when a read shows it at rest, else 502
//     saying what was sent and what the axis did. Attacked by
//     tests/serve/ops/operations_stop_test.cpp;
//   - an operation accepted while a stop, hold, reset or servo off accepted
//     before it still runs on the same axis waits for it to end before it
//     writes or reads anything, so the wire sees them in the order they were
//     accepted. A move sent right after a reset otherwise had its start reach
//     the controller between the reset's RESET <- 0 and its RESET <- 1, whose
//     edge then cancelled the move (502 "did not start"); a resume
//     (HOLD <- 0) could likewise land right after its hold's HOLD <- 1, and
//     the hold's judgement then saw the axis move on (502). While it waits,
//     a stop accepted after it, a jog let go, or lec serve shutting down end
//     it at once; after after_stop_wait (30 s) it is refused (409). Ended
//     so, nothing of it was sent: no "started" event (it comes when the wait
//     ends, after the awaited op's "finished"), and the axis is not left
//     "may still be moving". Stops and servo off never wait. Not ordered
//     this way: run_task's work (step data moves nothing) and a Modbus TCP
//     client's writes (not an operation of lec serve). Attacked by
//     tests/serve/ops/operations_test.cpp (AMoveAcceptedDuringAResetWaitsForItsPulse,
//     AResumeRightAfterAHoldResumes, AServoOffDuringAStopGoesAtOnce,
//     AJogReleasedWhileItWaitsForAStopSendsNothing,
//     AWaitingJogLetGoEndsAtOnceAndAWaitingMoveEndsAtShutdown,
//     AMoveThatWaitedTooLongForAStopIsRefusedAndLeavesTheAxisFree,
//     AStopWhileAMoveWaitsForAResetRefusesTheMove);
//   - a hold-to-run jog lives while its lease is renewed (repeating the jog
//     command), and ends on jog-stop, when its lease runs out, or when the
//     stream it was tied to closes (the browser went away): the daemon then
//     releases JOG itself;
//   - stopping the daemon releases running jogs first; moves are left to the
//     controller to finish.
//
// Results are JSON for the HTTP API and the MQTT bridge, with an HTTP-style
// status: 200 done (a move reached its target or pushed), 400 bad arguments,
// 409 refused by the axis' state (busy, servo off, parallel mode, blank step),
// 422 the controller could not do it (exception reply, alarm, push missed,
// stopped), 502 no answer, 503 line down or daemon stopping, 504 deadline.
//
// Thread safety: every public member may be called from any thread.

#include <atomic>
#include <condition_variable>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "lec6/client/client.hpp"
#include "lec6/serve/log.hpp"
#include "line/line.hpp"
#include "ops/axis_directory.hpp"
#include "ops/commands.hpp"

namespace lec6::serve {

struct OpResult {
  int status = 200;
  nlohmann::json body;
};

// What an axis is doing, for GET /api/axes/{name} and the dashboard.
struct OpStatus {
  std::string op;
  std::string source;  // "http 127.0.0.1", "mqtt", ...
  double running_s = 0;
  // The operation ended without the axis seen stopped (deadline, no answer):
  // the axis may still be moving; a new motion waits for BUSY = 0.
  bool unsettled = false;
  // Accepted, and waiting for the stop, hold, reset or servo off accepted
  // before it on its axis ("reset (by http 127.0.0.1)"): nothing of it has
  // reached the line; running_s counts from its acceptance. Empty: it runs.
  std::string waiting_for;
};

using OpObserver = std::function<void(const std::string& axis, const nlohmann::json& event)>;

class Operations {
 public:
  // `after_stop_wait`: how long an operation waits for the stops accepted
  // before it on its axis (the rule above), then refused.
  explicit Operations(Log log, Duration after_stop_wait = std::chrono::seconds(30));
  ~Operations();
  Operations(const Operations&) = delete;
  Operations& operator=(const Operations&) = delete;

  // Runs `cmd` on `axis`; `done` is called once, from another thread (or
  // at once for a refusal), with the result.
  void run(const AxisRef& axis, Command cmd, std::string source,
           std::function<void(OpResult)> done);
  // Runs any other client work on `axis` (step plans and restores) on an
  // operation thread, at client priority; not a motion, so never refused as busy.
  void run_task(const AxisRef& axis, std::string name, std::string source,
                std::function<OpResult(client::Client&)> task, std::function<void(OpResult)> done);
  // A motion of several axes that lec serve runs itself (a machine cycle:
  // serve/cycles/): takes the motion slot of every one of `axes`, or of none
  // (refused as a motion is: 409 when one is busy, may still be moving, or a
  // stop, hold, reset or servo off accepted before still runs on it; 503
  // while lec serve shuts down), then runs `work` on an operation thread.
  // Meanwhile another motion of those axes is refused with 409 naming
  // `what` ("cycle pick-place"). The `stopped` given to `work` turns true,
  // for good, once a stop, hold, reset or servo off of one of them is
  // accepted (any channel that goes through Operations; seen by the first
  // look after its acceptance, under the lock it was accepted under) or lec
  // serve begins to shut down;
  // `accepted` is when the claim was, on the first axis's line's clock. The
  // slots are freed when `work` returns (5xx: left unsettled, as a motion's);
  // `done` gets its result.
  struct Claim {
    TimePoint accepted{};
    std::function<bool()> stopped;
  };
  void run_claimed(const std::vector<AxisRef>& axes, std::string what, std::string source,
                   std::function<OpResult(const Claim&)> work, std::function<void(OpResult)> done);
  // Ties a running jog to a stream: when `closed()` turns true (checked as
  // the jog polls), the jog is released.
  void tie_jog(const std::string& axis, std::function<bool()> closed);

  // The motion under way on `axis`, or the one that ended unsettled (until a
  // read shows BUSY = 0: then nothing).
  std::optional<OpStatus> running(const AxisRef& axis) const;
  std::optional<nlohmann::json> last_result(const std::string& axis) const;
  void add_observer(OpObserver observer);

  // From now on only stop, hold and reset are taken (others: 503); running
  // jogs are released. Does not wait.
  void begin_shutdown();
  // No operation runs.
  bool idle() const;
  // begin_shutdown(), then waits (bounded) for the operations to end. Call
  // again after stopping the lines: every thread has ended then.
  void shutdown();

 private:
  struct Running;
  struct Unsettled;
  struct Slot;
  OpResult execute(const AxisRef& axis, const Command& cmd, Running& run);
  std::optional<OpResult> wait_for_stops(const Command& cmd, Running& run) const;
  static client::StopPolicy stop_policy(const AxisRef& axis);
  // `started`: the event to notify once the stops it waits for ended (null:
  // already notified).
  void start_thread(const AxisRef& axis, Command cmd, std::shared_ptr<Running> run,
                    nlohmann::json started, std::function<void(OpResult)> done);
  void finished(const AxisRef& axis, const std::shared_ptr<Running>& run, const OpResult& result);
  bool settled(const AxisRef& axis, const Unsettled& u) const;
  // run_claimed's thread: the work, then the slots freed and `done` called.
  void start_claimed(const std::vector<AxisRef>& axes,
                     const std::vector<std::shared_ptr<Running>>& runs,
                     std::function<OpResult(const Claim&)> work,
                     std::shared_ptr<std::function<void(OpResult)>> done_once);
  OpResult unsettled_refusal(const AxisRef& axis, const Unsettled& u) const;
  void notify(const std::string& axis, const nlohmann::json& event);

  Log log_;
  Duration after_stop_wait_;
  mutable std::mutex mutex_;
  std::map<std::string, Slot> slots_;
  std::vector<OpObserver> observers_;
  bool shutting_down_ = false;
  // Operation threads are detached; shutdown() waits for them to end.
  mutable std::mutex active_mutex_;
  std::condition_variable idle_;
  std::size_t active_ = 0;
  // An operation's thread (or its stand-in) begins / has ended: idle() and
  // shutdown() wait on the count.
  void began_one();
  void ended_one();
};

}  // namespace lec6::serve
