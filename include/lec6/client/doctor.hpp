#pragma once
// `lec doctor`'s judgement, sans-I/O: what the probes saw on the line goes in
// (Observations), findings come out, each in the manual's terms: what was
// seen, what it means, what to do. The CLI (cli/cmd_doctor.cpp) opens the
// port, listens and exchanges frames; everything that decides is here, so
// it is tested on constructed observations.
//
//   auto p = doctor::classify_exchange(query, bytes_heard_until_deadline);
//   ...fill Observations from the probes...
//   doctor::Report r = doctor::diagnose(obs);   // r.health, r.findings
//
// Thread safety: value types and pure functions.

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "lec6/clock.hpp"
#include "lec6/modbus/timing.hpp"

namespace lec6::client::doctor {

// ---- one exchange -------------------------------------------------------------

enum class ReplyKind {
  None,       // nothing came back (beyond our own echo)
  Good,       // a whole reply from the ID asked, CRC sound
  Exception,  // a sound exception reply (the controller is there)
  Crc,        // a reply from the ID asked, but its CRC fails (collision, noise, wrong baud)
  Framing,    // a reply from the ID asked that ended early or cannot be sized
  Garbage,    // bytes, but no reply from the ID asked among them
};

// A sound reply, data or exception: the controller asked is there and heard us.
constexpr bool answered(ReplyKind k) noexcept {
  return k == ReplyKind::Good || k == ReplyKind::Exception;
}

struct ExchangeResult {
  bool echo = false;  // the query came back first, byte for byte (2-wire adapter)
  ReplyKind kind = ReplyKind::None;
  std::size_t reply_offset = 0;  // where the reply starts in the bytes heard (after the echo)
  std::size_t reply_bytes = 0;   // its length (Good, Exception, Crc)
  std::size_t noise_bytes = 0;   // bytes that are neither our echo nor the reply
};

// Classifies what was heard after sending `query` (all bytes until the
// reply window closed): echo, reply, noise.
ExchangeResult classify_exchange(std::span<const uint8_t> query, std::span<const uint8_t> heard);

// Sound request frames (CRC holds, length fits) found in bytes heard while we
// were silent: another master's queries. Returns their IDs, one per frame.
std::vector<uint8_t> foreign_queries(std::span<const uint8_t> heard);

// ---- what the probes saw --------------------------------------------------------

struct BaudProbe {
  uint32_t baud = 0;
  std::vector<uint8_t> answering;  // sound replies (or exceptions)
  std::vector<uint8_t> garbled;    // replies with the right ID but a failed CRC / framing
  std::size_t stray_bytes = 0;     // bytes that were no reply at all
  bool echo = false;               // our queries came back
  // Of `garbled`, those garbled again when asked again (never sound): a
  // controller there whose replies collide, not noise that began with its ID.
  std::vector<uint8_t> garbled_again{};
};

struct BurstStats {
  int exchanges = 0;
  int good = 0;
  int timeouts = 0;  // no whole reply, not even within one more margin after the window
  // Whole, sound replies that came after their window (Tx + margin), within
  // one more margin: a slow controller, adapter or host, not a lost frame.
  int late = 0;
  int crc = 0;
  int framing = 0;
  uint64_t noise_bytes = 0;
  // Per ID: exchanges, and replies garbled though they carried that ID.
  std::map<uint8_t, int> per_id_exchanges;
  std::map<uint8_t, int> per_id_garbled;
  // Round trips of sound replies: first byte of the query sent → reply complete.
  std::vector<Duration> round_trips;
  std::size_t query_bytes = 8;
  std::size_t reply_bytes = 19;
  // Most replies came sooner than their bytes take on the wire at this
  // baud: no real line carries them (a virtual port, a twin with fast
  // timing). Those replies count as good; timing is not judged.
  bool unpaced = false;
};

struct ControllerState {
  uint8_t id = 0;
  std::string read_error;    // non-empty: the state could not be read
  bool serial_mode = false;  // Y30
  bool servo_on = false;     // SVON
  bool svre = false;         // servo ready
  bool homed = false;        // SETON
  bool estop = false;
  std::vector<uint8_t> alarms;  // active (X4F and the alarm code agree, lec/alarm_check.hpp)
  // X4F and the alarm code (or BUSY) disagree: what, and the setting that fixes it.
  std::string alarm_check;
  std::string name;  // equipment name D000E
  // What --fix did: "serial mode on (Y30)", "alarm 62 cleared (RESET)".
  std::vector<std::string> fixed;
};

struct Observations {
  std::string port;      // as the user named it
  bool gateway = false;  // tcp:// (lec serve or another gateway): no line of ours to probe
  std::string id_range = "1-32";
  modbus::LineTiming assumed;  // lec6's assumption (baud is the one found, when found)
  bool echo_option = false;    // --echo was given
  bool fix = false;            // --fix was given

  std::vector<BaudProbe> bauds;  // in the order tried
  std::optional<uint32_t> found_baud;
  bool budget_ran_out = false;  // the search stopped at its deadline

  // Echo: seen at some baud; whether a transaction with echo discard worked.
  bool echo_seen = false;
  std::optional<bool> echo_fix_works;

  // The USB adapter's latency timer (sysfs), when there is one.
  std::optional<int> latency_timer_ms;
  std::string latency_timer_path;
  std::optional<bool> latency_fixed;  // --fix tried: true set, false refused (permission)

  // Listening before we sent anything (at the first baud, and at the found one).
  Duration listened{};
  std::size_t foreign_bytes = 0;
  std::vector<uint8_t> foreign_query_ids;  // one per sound query frame heard

  // Silent INT: a query sent in two parts this far apart was still taken as
  // one frame (the controller's Ts is longer), or nullopt: not seen (the
  // gap tried, gap_tried, ended the frame, as lec assumes).
  std::optional<Duration> ts_above;
  Duration ts_gap_tried{};

  BurstStats burst;
  std::vector<ControllerState> controllers;
};

// ---- what it means ------------------------------------------------------------

enum class Severity { Info, Warning, Error };  // Warning: degraded; Error: broken
enum class Health { Healthy, Degraded, Broken };

struct Finding {
  std::string check;  // baud, echo, usb-latency, timing, line-quality, other-master,
                      // duplicate-id, controller
  Severity severity = Severity::Info;
  std::string saw;
  std::string means;
  std::string todo;  // empty: nothing to do
  std::optional<uint8_t> id;
};

struct Report {
  Health health = Health::Healthy;
  std::vector<Finding> findings;
};

Report diagnose(const Observations& obs);

// The burst's replies that came sooner than the wire allows (`too_fast`, not
// counted in `b` yet). On a real line such a reply is the previous query's
// late one: a timeout. When most are (half or more of the replies, with
// hardly any query unanswered), no wire paces the port: they are answers,
// and b.unpaced is set. Call it after the burst (b.timeouts counted).
void account_too_fast(BurstStats& b, int too_fast);

std::string_view to_string(Severity s) noexcept;
std::string_view to_string(Health h) noexcept;

// "1 and 3", "1, 2 and 5".
std::string join_ids(const std::vector<uint8_t>& ids);

}  // namespace lec6::client::doctor
