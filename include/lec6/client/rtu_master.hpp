#pragma once
// Modbus RTU on a byte Link, with the manual's timing (digest §1): before
// sending, the line must have been silent for Ts; a reply completes the
// moment its expected length is in; it times out at Tx + margin after the
// query; after a broadcast the master waits Tx. The sans-I/O Transaction
// (transaction.hpp) decides; this class only moves its bytes.
//
// Thread safety: one thread at a time (it owns the line while it runs).

#include <functional>
#include <optional>
#include <random>

#include "lec6/client/master.hpp"
#include "lec6/client/transaction.hpp"

namespace lec6::client {

struct RtuOptions {
  unsigned silent_interval_k = 1;                           // the controller's "Silent INT"
  Duration delay_td = std::chrono::milliseconds(5);         // the controller's "Min Resp delay"
  Duration timeout_margin = std::chrono::milliseconds(50);  // added to Tx
  // Wait for Ts of line silence before each query (manual §8.2: a controller
  // delimits frames by it). Keep it on for any real RS485 line. Off only for
  // peers that frame by length (a `--timing fast` twin, software benchmarks),
  // where it would measure the line rule rather than the software.
  bool wait_for_silence = true;
  // Before sleeping on the port for a reply, look for it without sleeping
  // for this long (busy-waiting: the core is this process's meanwhile). Only
  // on the wall clock, counted from the query's end, at most kMaxReplySpin.
  // Zero (the default) for any real line, whose replies take milliseconds;
  // for a peer that answers in tens of microseconds (a `--timing fast` twin,
  // a benchmark: kFastReplySpin, `lec --reply-spin 150us`) a process put to
  // sleep pays the kernel's wake-up on every reply, a fifth of the round trip
  // on a 2-core VM (BENCHMARKS.md, "Fast mode"). Attacked by ReplySpin.*
  // (tests/twin/reply_spin_test.cpp): a silent ID still times out at its
  // deadline; no spin on a virtual clock; Ctrl-C still ends the wait.
  Duration reply_spin{};
  TraceSink trace{};  // every frame, when set
  // Ctrl-C: when set and true, the waits of an exchange (the silence before
  // it, the reply after it) end at once with Cancelled, checked at least
  // every kInterruptCheck; a query not sent yet is not sent. Requests that
  // stop or release the axis (client/interrupt.hpp) are never interrupted,
  // so a stop after Ctrl-C still goes out.
  std::function<bool()> interrupted{};
  // Seeds the pause drawn after a failed transaction (RtuMaster::kBackoffChars).
  // Unset: from the process on the wall clock; on a virtual clock, 1 + the
  // number of RtuMasters this process made before (rtu_master.cpp).
  std::optional<uint32_t> backoff_seed{};
};

inline constexpr Duration kInterruptCheck = std::chrono::milliseconds(20);
// RtuOptions::reply_spin for a fast peer: longer than a fast twin's round trip
// on a pty (~50-80 us), short enough that a lost reply costs little CPU.
inline constexpr Duration kFastReplySpin = std::chrono::microseconds(150);
inline constexpr Duration kMaxReplySpin = std::chrono::milliseconds(1);

class RtuMaster final : public Master {
 public:
  explicit RtuMaster(Link& link, RtuOptions options = {});

  modbus::ResponseFrame exchange(const modbus::RequestFrame& frame) override;
  const Clock& clock() const override { return link_.clock(); }
  std::string describe() const override { return link_.describe(); }
  LinkStats stats() const override { return stats_; }
  Duration last_round_trip() const override { return last_round_trip_; }
  std::optional<WireTimes> last_wire_times() const override { return last_wire_times_; }
  const modbus::LineTiming& line_timing() const override { return timing_.line; }
  Link* link() noexcept override { return &link_; }
  // Listens to the line until `t`: bytes that arrive (noise, a late reply)
  // are drained and counted, and the silence rule counts from the last one.
  void idle_until(TimePoint t) override;

  const TransactionTiming& timing() const noexcept { return timing_; }

  // After a failed transaction the next query waits its reply window and then
  // a drawn pause of 0 to kBackoffChars character times (rtu_master.cpp).
  static constexpr std::size_t kBackoffChars = 64;

 private:
  Duration failure_pause();
  // `urgent`: the query stops or releases the axis; `to`: its ID.
  void wait_for_silence(bool interruptible, bool urgent, uint8_t to);
  // read_some with the deadline cut to the next interrupt check; `exact`:
  // the deadline is an instant to keep (Link::read_some_exact).
  std::size_t read_some(std::span<uint8_t> buffer, TimePoint deadline, bool interruptible,
                        bool exact = false);
  std::size_t spin_then_read(std::span<uint8_t> buffer, TimePoint sent, TimePoint deadline,
                             bool interruptible);
  void check_interrupt(bool interruptible, std::string_view during);
  void trace(bool outgoing, TimePoint at, std::span<const uint8_t> bytes,
             const modbus::RequestFrame& request, const modbus::ResponseFrame* response);

  Link& link_;
  RtuOptions options_;
  TransactionTiming timing_;
  TimePoint line_busy_until_{};
  TimePoint
      hold_until_{};  // after a failure: no query before the failed one's reply window is over
  std::minstd_rand backoff_;  // draws the pause after a failure (failure_pause)
  Duration spin_;             // RtuOptions::reply_spin on the wall clock, else zero
  Duration pause_{};          // the last one drawn, waited beyond hold_until_
  uint8_t failed_id_ = 0;     // the ID the failed transaction was for
  LinkStats stats_;
  Duration last_round_trip_{};
  std::optional<WireTimes> last_wire_times_;
};

}  // namespace lec6::client
