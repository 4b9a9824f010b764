#include "lec6/client/rtu_master.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <random>

#include "lec6/client/interrupt.hpp"
#include "lec6/lec/explain.hpp"

namespace lec6::client {
namespace {

// The seed of the pause after a failure: from the process on the wall clock
// (two `lec` on one line must draw differently); on a virtual clock the
// masters' count in this process (a simulation that makes its masters in the
// same order repeats, with one standard library: the distribution's algorithm
// is the library's; two masters on one simulated line still draw apart).
uint32_t backoff_seed(const Clock& clock, std::optional<uint32_t> chosen) {
  static std::atomic<uint32_t> made{0};
  if (chosen) return *chosen;
  if (dynamic_cast<const SteadyClock*>(&clock) == nullptr) return 1 + made++;
  return std::random_device{}();
}

// A look at the line this much later than asked was a late wake (the host
// ran something else): what it finds says nothing of the silence before it.
constexpr Duration kLateWake = std::chrono::milliseconds(10);
// How many times the silence bound may start again after late wakes.
constexpr int kLateWakeWindows = 3;

TransportErrorKind kind_of(LinkErrorKind k) {
  return k == LinkErrorKind::EchoMismatch ? TransportErrorKind::EchoMismatch
                                          : TransportErrorKind::Port;
}

}  // namespace

RtuMaster::RtuMaster(Link& link, RtuOptions options)
    : link_(link),
      options_(std::move(options)),
      backoff_(backoff_seed(link.clock(), options_.backoff_seed)),
      // A virtual clock stands still while nothing waits on it: no spin there.
      // At most kMaxReplySpin: a longer busy-wait only burns the core (and
      // would hold off a Ctrl-C past kInterruptCheck).
      spin_(dynamic_cast<const SteadyClock*>(&link.clock())
                ? std::clamp(options_.reply_spin, Duration{}, kMaxReplySpin)
                : Duration{}) {
  timing_.line.baud = link_.baud();
  timing_.line.silent_interval_k = options_.silent_interval_k;
  timing_.line.delay_td = options_.delay_td;
  timing_.margin = options_.timeout_margin;
  line_busy_until_ = link_.clock().now();  // listen for Ts before the first query too
}

void RtuMaster::trace(bool outgoing, TimePoint at, std::span<const uint8_t> bytes,
                      const modbus::RequestFrame& request, const modbus::ResponseFrame* response) {
  if (!options_.trace) return;
  std::string text =
      outgoing ? lec::explain_request(request)
               : (response ? lec::explain_response(*response, &request) : std::string("?"));
  options_.trace(TraceEvent{outgoing, at, bytes, std::move(text)});
}

// The manual's frame delimiter works both ways: the controller must see Ts of
// silence before our query, so anything still arriving (a late reply, noise)
// is drained until the line has been quiet for Ts — also before the first
// query, since the master cannot know what the line was doing before it
// listened. After a failed transaction the next query also waits until a
// whole reply window has passed since the failure: a reply later than our
// timeout would otherwise land in the next transaction, and Modbus RTU has no
// transaction ID to tell it from a fresh reply of the same shape. (Only Ts
// of silence is asked after the last byte: idle-line noise must not turn
// that hold into a wait for a silence that never comes.)
// The wait is bounded: a line that never goes quiet (noise, a second master)
// fails within a transaction timeout instead of hanging. Only time the master
// watched counts against that bound: bytes found after a wake later than
// asked (a loaded host; CI, stop 40: a twin's noise at 50 bytes/s read as
// "never silent" after one such wake) may have had Ts of silence before them
// unseen, so the bound starts again from that wake, at most kLateWakeWindows
// times: a line that is really busy still fails, a little later (a stop on
// it too: up to that many windows later, and only when the host stalls).
void RtuMaster::wait_for_silence(bool interruptible, bool urgent, uint8_t to) {
  const Duration quiet = options_.wait_for_silence ? timing_.line.silent_interval() : Duration{};
  const TimePoint began = link_.clock().now();
  // A stop or release to another ID (or a broadcast: no reply) waits neither
  // the late-reply hold nor the drawn pause, only Ts of silence (below); to
  // the ID whose reply was lost it waits the hold: see failure_pause.
  const bool skip = urgent && (to != failed_id_ || to == modbus::kBroadcastId);
  const TimePoint held = skip ? TimePoint{} : hold_until_ + (urgent ? Duration{} : pause_);
  const Duration window = quiet + timing_.line.response_time(modbus::kMaxAdu) + timing_.margin;
  TimePoint give_up = std::max(began, held) + window;
  // Bytes seen at `seen`, by a look meant for `asked`: when the look came
  // late, the bound starts again from it (a whole window to watch, however
  // long the stall was), kLateWakeWindows times at most.
  int restarts = 0;
  const auto heard = [&](TimePoint asked, TimePoint seen) {
    if (seen - asked > kLateWake && restarts < kLateWakeWindows) {
      ++restarts;
      give_up = std::max(give_up, seen + window);
    }
  };
  std::array<uint8_t, 256> sink;  // only read into
  const auto never_silent = [&] {
    return TransportError(
        TransportErrorKind::LineBusy,
        fmt::format("line never silent for Ts ({:.2f} ms) within {:.1f} ms before sending: "
                    "noise on the line, or another master talking",
                    to_ms(quiet), to_ms(give_up - began)));
  };
  for (;;) {
    const TimePoint now = link_.clock().now();
    const TimePoint quiet_at = std::max(line_busy_until_ + quiet, held);
    if (now >= quiet_at) {
      // Silent by the clock since the last byte we saw: one look at the line
      // without waiting for what arrived unseen since then (the caller may
      // have been busy between transactions). Bytes there mean the line was
      // not silent: they are dropped and counted, and Ts starts again. (This
      // look replaced a flush of the input: as many system calls, a lighter
      // one, and what it drops is counted and recorded.)
      const std::size_t n = link_.read_some(sink, TimePoint{});
      if (n == 0) return;
      stats_.bytes_discarded += n;
      line_busy_until_ = link_.clock().now();
      heard(quiet_at, line_busy_until_);
      if (line_busy_until_ >= give_up) throw never_silent();
      continue;
    }
    if (now >= give_up) throw never_silent();
    check_interrupt(interruptible, "waiting for the line to fall silent; nothing was sent");
    // The end of Ts is an instant to keep (every late microsecond is lost
    // line time, issue 12); the give-up bound is not.
    const TimePoint until = std::min(quiet_at, give_up);
    // The deadline read_some keeps: an interruptible wait looks up every kInterruptCheck.
    const TimePoint asked = interruptible ? std::min(until, now + kInterruptCheck) : until;
    const std::size_t n = read_some(sink, until, interruptible, quiet_at <= give_up);
    if (n > 0) {
      stats_.bytes_discarded += n;
      line_busy_until_ = link_.clock().now();
      heard(asked, line_busy_until_);
    }
  }
}

// RtuOptions::reply_spin: zero-timeout looks (a poll each) until a byte or
// the spin's end, then the usual sleeping read. The spin is counted from the
// query's end: one per transaction, however many reads its reply takes.
std::size_t RtuMaster::spin_then_read(std::span<uint8_t> buffer, TimePoint sent, TimePoint deadline,
                                      bool interruptible) {
  const TimePoint until = std::min(deadline, sent + spin_);
  do {
    if (const std::size_t n = link_.read_some(buffer, TimePoint{}); n > 0) return n;
  } while (link_.clock().now() < until);
  return read_some(buffer, deadline, interruptible);
}

void RtuMaster::check_interrupt(bool interruptible, std::string_view during) {
  if (interruptible && options_.interrupted()) {
    throw Cancelled(fmt::format("interrupted while {}", during));
  }
}

std::size_t RtuMaster::read_some(std::span<uint8_t> buffer, TimePoint deadline, bool interruptible,
                                 bool exact) {
  if (interruptible) {
    const TimePoint check = link_.clock().now() + kInterruptCheck;
    if (check < deadline) deadline = check, exact = false;  // only a check, not the instant
  }
  return exact ? link_.read_some_exact(buffer, deadline) : link_.read_some(buffer, deadline);
}

// After a failure the line is held for the failed query's reply window (a
// late reply must not land in the next transaction), then for a drawn pause
// of 0 to kBackoffChars character times. A query that stops or releases the
// axis (client::stops_or_releases) never waits the drawn pause; to another
// ID than the failed query's (or a broadcast) it waits only for Ts of
// silence, listening (a late reply already under way is heard and waited
// for): behind a dead neighbour on lec serve's line the hold cost every stop
// a second reply window (the line simulation: the operators' stops' p99
// 311 ms with it). A late reply from another ID cannot pass for the stop's
// (the reply must carry the stop's ID); one that begins while the stop is on
// the wire garbles it, and the stop is resent. To the same ID the hold stays:
// a late echo of an earlier write to the same coil or block can look like
// the stop's own reply (a reviewer's finding: HOLD <- 0's echo taken for
// HOLD <- 1's). Two masters on one line (a
// second PC, an HMI during commissioning) whose frames collided both time out at the same instant;
// with the same fixed hold they would resend together and collide again on every attempt
// (motion_truth_test saw 11 attempts lost in a row). The drawn pause is the classic way out
// (Ethernet's backoff); one master alone pays ~32 character times on a resend that already waited a
// whole reply window.
Duration RtuMaster::failure_pause() {
  const Duration most = timing_.line.wire_time(kBackoffChars);
  return Duration(std::uniform_int_distribution<Duration::rep>(0, most.count())(backoff_));
}

void RtuMaster::idle_until(TimePoint t) {
  std::array<uint8_t, 256> sink{};
  try {
    while (link_.clock().now() < t) {
      check_interrupt(static_cast<bool>(options_.interrupted), "waiting between polls");
      const std::size_t n = read_some(sink, t, static_cast<bool>(options_.interrupted));
      if (n > 0) {
        stats_.bytes_discarded += n;
        line_busy_until_ = link_.clock().now();
      }
    }
  } catch (const LinkError& e) {
    throw TransportError(kind_of(e.kind()), e.what());
  }
}

modbus::ResponseFrame RtuMaster::exchange(const modbus::RequestFrame& frame) {
  Transaction tx(frame, timing_);
  std::array<uint8_t, modbus::kMaxAdu * 2> buffer;  // only read into
  const bool interruptible =
      static_cast<bool>(options_.interrupted) && !stops_or_releases(frame.pdu);
  try {
    check_interrupt(interruptible, "about to send; nothing was sent");
    wait_for_silence(interruptible, stops_or_releases(frame.pdu), frame.id);
    const TimePoint start = link_.clock().now();
    link_.write(tx.bytes());
    tx.sent(link_.clock().now());
    trace(true, start, tx.bytes(), frame, nullptr);
    while (tx.step() == Transaction::Step::Receive) {
      if (interruptible && options_.interrupted()) {
        line_busy_until_ = link_.clock().now();
        hold_until_ = link_.clock().now() + (tx.deadline() - tx.sent_at());  // its reply may come
        pause_ = {};
        failed_id_ = frame.id;
        throw Cancelled(
            "interrupted while waiting for the reply: the request was sent and may "
            "have been carried out");
      }
      const std::size_t n = spin_ > Duration::zero()
                                ? spin_then_read(buffer, tx.sent_at(), tx.deadline(), interruptible)
                                : read_some(buffer, tx.deadline(), interruptible);
      const TimePoint now = link_.clock().now();
      if (n > 0) {
        tx.received(std::span(buffer.data(), n), now);
      } else if (now >= tx.deadline()) {
        tx.timed_out(now);
      }
    }
    line_busy_until_ = link_.clock().now();
    stats_.busy += line_busy_until_ - start;
    ++stats_.transactions;
    stats_.bytes_discarded += tx.discarded();
    if (tx.step() == Transaction::Step::Failed) {
      hold_until_ = link_.clock().now() + (tx.deadline() - tx.sent_at());
      pause_ = failure_pause();
      failed_id_ = frame.id;
      switch (tx.error_kind()) {
        case TransportErrorKind::Timeout:
          ++stats_.timeouts;
          break;
        case TransportErrorKind::Crc:
          ++stats_.crc_errors;
          break;
        default:
          ++stats_.framing_errors;
          break;
      }
      throw TransportError(tx.error_kind(), tx.error());
    }
    if (tx.broadcast())
      return modbus::ResponseFrame{modbus::kBroadcastId, modbus::WriteMultipleResponse{}};
    last_round_trip_ = tx.finished_at() - start;
    last_wire_times_ = WireTimes{start, tx.finished_at()};
    modbus::ResponseFrame reply = tx.take_response();
    if (options_.trace) trace(false, tx.finished_at(), encode_response(reply), frame, &reply);
    return reply;
  } catch (const LinkError& e) {
    line_busy_until_ = link_.clock().now();
    hold_until_ =
        link_.clock().now() + timing_.line.response_time(modbus::kMaxAdu) + timing_.margin;
    pause_ = {};
    failed_id_ = frame.id;
    throw TransportError(kind_of(e.kind()), e.what());
  }
}

}  // namespace lec6::client
