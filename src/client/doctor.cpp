// lec doctor: from what the probes saw to findings (what was seen, what it
// means, what to do), in the manual's terms. Sans-I/O.

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "lec6/client/doctor.hpp"
#include "lec6/lec/alarms.hpp"

namespace lec6::client::doctor {

namespace {

double ms(Duration d) {
  return std::chrono::duration<double, std::milli>(d).count();
}

std::string per_k(int n, int of) {
  return of > 0 ? fmt::format("{:.0f}", 1000.0 * n / of) : "0";
}

// The options a `lec` command needs for this line, e.g. " --baud 57600 --echo".
std::string line_options(const Observations& o) {
  std::string out;
  if (o.found_baud && *o.found_baud != modbus::kDefaultBaud)
    out += fmt::format(" --baud {}", *o.found_baud);
  if (o.echo_seen) out += " --echo";
  return out;
}

std::string lec_cmd(const Observations& o, uint8_t id, std::string_view what) {
  return fmt::format("lec --port {}{} --id {} {}", o.port, line_options(o), id, what);
}

Duration median(std::vector<Duration> v) {
  if (v.empty()) return {};
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

class Builder {
 public:
  explicit Builder(const Observations& o) : o_(o) {}

  void add(std::string check, Severity s, std::string saw, std::string means, std::string todo,
           std::optional<uint8_t> id = std::nullopt) {
    r_.findings.push_back(
        {std::move(check), s, std::move(saw), std::move(means), std::move(todo), id});
  }

  Report take() {
    for (const auto& f : r_.findings) {
      if (f.severity == Severity::Error) r_.health = Health::Broken;
      if (f.severity == Severity::Warning && r_.health == Health::Healthy)
        r_.health = Health::Degraded;
    }
    return std::move(r_);
  }

  void baud_and_ids();
  void echo();
  void gateway();
  void other_master();
  void usb_latency();
  void timing();
  void line_quality();
  void controllers();

 private:
  const Observations& o_;
  Report r_;
};

void Builder::baud_and_ids() {
  std::vector<std::string> silent;
  std::vector<std::string> garbled_at;
  for (const auto& b : o_.bauds) {
    if (o_.found_baud && b.baud == *o_.found_baud) continue;
    if (!b.garbled.empty()) {
      garbled_at.push_back(fmt::format("{} (ID {})", b.baud, join_ids(b.garbled)));
    } else {
      silent.push_back(std::to_string(b.baud));
    }
  }
  std::string others;
  if (!silent.empty()) {
    others = "; nothing at ";
    for (std::size_t i = 0; i < silent.size(); ++i) others += (i ? ", " : "") + silent[i];
  }
  if (o_.found_baud) {
    const BaudProbe* at = nullptr;
    for (const auto& b : o_.bauds)
      if (b.baud == *o_.found_baud) at = &b;
    const auto& ids = at->answering;
    const std::string todo =
        *o_.found_baud == modbus::kDefaultBaud
            ? std::string()
            : fmt::format("give --baud {} to every lec command (lec's default is {})",
                          *o_.found_baud, modbus::kDefaultBaud);
    add("baud", Severity::Info, fmt::format("ID {} at {}{}", join_ids(ids), *o_.found_baud, others),
        fmt::format("{} answer{} at {} baud (IDs {} scanned)",
                    ids.size() == 1 ? "one controller" : fmt::format("{} controllers", ids.size()),
                    ids.size() == 1 ? "s" : "", *o_.found_baud, o_.id_range),
        todo);
    return;
  }
  std::string saw = fmt::format("nothing answers at any baud ({} IDs {})",
                                o_.bauds.size() == std::size(modbus::kBaudRates)
                                    ? std::string("9600 ... 230400,")
                                    : fmt::format("{} of 6 rates tried,", o_.bauds.size()),
                                o_.id_range);
  if (!garbled_at.empty()) {
    saw += "; garbled replies at ";
    for (std::size_t i = 0; i < garbled_at.size(); ++i) saw += (i ? ", " : "") + garbled_at[i];
  }
  if (o_.budget_ran_out) saw += "; the search stopped at its time budget";
  add("baud", Severity::Error, saw,
      "no controller on this port answers a read of D9000 (state data)",
      "check, in order: the controller is powered (PWR LED on) and not in an alarm that stops "
      "communication; the cable goes to the controller's serial (CN?) connector and A/B (+/-) "
      "are not swapped; this port is the adapter on that cable (lec ports lists them); the "
      "controller's ID is within " +
          o_.id_range +
          " and its baud rate is one of 9600 ... 230400 (controller setting "
          "software); the line has 120 ohm termination at its far end");
}

void Builder::gateway() {
  const std::vector<uint8_t> ids =
      o_.bauds.empty() ? std::vector<uint8_t>{} : o_.bauds.back().answering;
  if (ids.empty()) {
    add("gateway", Severity::Error,
        fmt::format("no ID of {} answers through {}", o_.id_range, o_.port),
        "the gateway answers, but no controller behind it does (or none is configured with "
        "these IDs)",
        "check the gateway's configuration (lec serve --ids) and its log; to check the line "
        "itself, stop the gateway and run lec doctor on its serial port");
    return;
  }
  add("gateway", Severity::Info,
      fmt::format("ID {} answer{} through {}", join_ids(ids), ids.size() == 1 ? "s" : "", o_.port),
      "the line's own checks (baud, echo, USB latency, timing, noise, another master) need the "
      "serial port, which the gateway holds",
      "to check the line itself: stop the gateway (lec serve) and run lec doctor --port "
      "/dev/ttyUSB0 (its port)");
}

void Builder::echo() {
  if (!o_.echo_seen) return;
  if (o_.echo_fix_works.value_or(false)) {
    add("echo", o_.echo_option ? Severity::Info : Severity::Error,
        "every query came back to us byte for byte before the reply",
        "the adapter is 2-wire and hears its own transmission (local echo); lec without --echo "
        "reads the echo as a reply and fails",
        o_.echo_option ? std::string()
                       : std::string("add --echo to every lec command (verified: with --echo "
                                     "the transactions work)"));
  } else if (o_.echo_fix_works) {
    add("echo", Severity::Error, "every query came back to us byte for byte",
        "the adapter hears its own transmission (local echo), and even with echo discard no "
        "transaction worked",
        "add --echo; if it still fails, check the adapter's echo / RTS (direction) setting");
  } else {
    add("echo", o_.echo_option ? Severity::Info : Severity::Warning,
        "every query came back to us byte for byte",
        "the adapter hears its own transmission (local echo): a 2-wire adapter",
        o_.echo_option ? std::string()
                       : std::string("add --echo to every lec command (not verified: no "
                                     "controller answered)"));
  }
}

void Builder::other_master() {
  if (o_.foreign_query_ids.empty() && o_.foreign_bytes == 0) return;
  const double s = std::max(std::chrono::duration<double>(o_.listened).count(), 1e-3);
  if (!o_.foreign_query_ids.empty()) {
    std::vector<uint8_t> ids = o_.foreign_query_ids;
    std::sort(ids.begin(), ids.end());
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
    add("other-master", Severity::Error,
        fmt::format("{} queries to ID {} heard in {:.1f} s of listening before lec sent anything "
                    "({:.1f}/s)",
                    o_.foreign_query_ids.size(), join_ids(ids), s,
                    static_cast<double>(o_.foreign_query_ids.size()) / s),
        "another master polls this line; Modbus RTU allows one master, so its frames collide "
        "with ours (lost replies, CRC errors, a controller answering the wrong master)",
        "stop the other master (a PLC, an HMI, the setting software, another lec) or disconnect "
        "it; to share the line, let lec serve own it and point the others at its Modbus TCP "
        "port (tcp://HOST:1502)");
  } else if (o_.foreign_bytes > 0) {
    add("other-master", Severity::Warning,
        fmt::format("{} bytes heard in {:.1f} s of listening before lec sent anything, none of "
                    "them a sound frame",
                    o_.foreign_bytes, s),
        "the idle line is not quiet: noise (missing bias or termination), or a master at "
        "another baud rate",
        "see line quality below; if a PLC or HMI is connected, stop it and run lec doctor again");
  }
}

void Builder::usb_latency() {
  const auto& b = o_.burst;
  if (b.unpaced) return;  // said under timing
  const Duration limit = o_.assumed.transaction_limit(b.query_bytes, b.reply_bytes);
  const Duration med = median(b.round_trips);
  std::string measured;
  if (!b.round_trips.empty())
    measured = fmt::format("; the round trip is {:.1f} ms (median) against the manual's {:.1f} ms",
                           ms(med), ms(limit));
  if (o_.latency_timer_ms) {
    if (*o_.latency_timer_ms <= 1) {
      add("usb-latency", Severity::Info,
          fmt::format("latency timer {} ms ({}){}", *o_.latency_timer_ms, o_.latency_timer_path,
                      measured),
          "the USB adapter passes received bytes on at once", "");
      return;
    }
    if (o_.latency_fixed.value_or(false)) {
      add("usb-latency", Severity::Info,
          fmt::format("latency timer was {} ms; --fix set it to 1 ms ({}){}", *o_.latency_timer_ms,
                      o_.latency_timer_path, measured),
          "the USB adapter now passes received bytes on at once",
          "make it permanent with a udev rule: ACTION==\"add\", SUBSYSTEM==\"usb-serial\", "
          "DRIVER==\"ftdi_sio\", ATTR{latency_timer}=\"1\"");
      return;
    }
    add("usb-latency", Severity::Warning,
        fmt::format("latency timer {} ms ({}){}", *o_.latency_timer_ms, o_.latency_timer_path,
                    measured),
        fmt::format("the USB adapter holds received bytes up to {} ms before passing them on: "
                    "every reply arrives late, and the transaction rate drops",
                    *o_.latency_timer_ms),
        fmt::format("{}echo 1 | sudo tee {} (or run lec doctor --fix as root; a udev rule makes "
                    "it permanent)",
                    o_.latency_fixed ? "--fix was refused (permission); run " : "",
                    o_.latency_timer_path));
    return;
  }
  // No timer to read: the measurement alone. Lumps of whole ms beyond the
  // controller's own time, varying from one exchange to the next, are the
  // signature of a USB adapter's latency timer.
  if (b.round_trips.size() < 5) return;
  std::vector<Duration> sorted = b.round_trips;
  std::sort(sorted.begin(), sorted.end());
  const Duration lo = sorted.front();
  const Duration p25 = sorted[sorted.size() / 4];
  const Duration spread = med - lo;
  // A latency timer spreads round trips evenly over its period (the first
  // quarter already milliseconds above the fastest); a busy host delays a
  // few by a few ms. Beyond what the host adds:
  if (spread > std::chrono::milliseconds(6) && p25 - lo > std::chrono::microseconds(2500) &&
      med > limit + std::chrono::milliseconds(6)) {
    // Information only: a busy host (or a twin on one) looks the same.
    add("usb-latency", Severity::Info,
        fmt::format("round trips vary from {:.1f} to {:.1f} ms (median) against the manual's "
                    "{:.1f} ms",
                    ms(lo), ms(med), ms(limit)),
        "replies are held back by a varying lump of milliseconds: a USB adapter's latency timer "
        "(FTDI default 16 ms), a busy converter, or a busy host",
        "set the adapter's latency timer to 1 ms: echo 1 | sudo tee "
        "/sys/bus/usb-serial/devices/ttyUSB0/latency_timer (the name of your port)");
  }
}

void Builder::timing() {
  const auto& b = o_.burst;
  if (b.unpaced) {
    add("timing", Severity::Info,
        fmt::format("replies came sooner than {} bytes take at {} baud",
                    b.query_bytes + b.reply_bytes, o_.assumed.baud),
        "no RS485 line paces this port (a virtual port, or a twin with --timing fast): timing "
        "and the USB latency timer cannot be judged here",
        "");
    return;
  }
  if (b.round_trips.size() < 3) return;
  const Duration lo = *std::min_element(b.round_trips.begin(), b.round_trips.end());
  const modbus::LineTiming& t = o_.assumed;
  const Duration wires = t.wire_time(b.query_bytes) + t.wire_time(b.reply_bytes);
  // End of query -> start of reply, as the controller took it: Ts + T0 + Td.
  const Duration turnaround = lo - wires;
  const Duration assumed = t.silent_interval() + modbus::LineTiming::kProcessing + t.delay_td;
  if (o_.ts_above) {
    // A gap this long did not end the frame: Silent INT is above lec's k.
    const double char_ms = ms(t.char_time());
    const unsigned k_min = static_cast<unsigned>(std::ceil(ms(*o_.ts_above) / (3.5 * char_ms)));
    add("timing", Severity::Warning,
        fmt::format("a query sent in two parts {:.1f} ms apart was answered as one frame",
                    ms(*o_.ts_above)),
        fmt::format("the controller's Silent INT is at least {} (Ts >= {:.1f} ms), not {} as lec "
                    "assumes: lec's pacing and frame ends are then too short",
                    k_min, ms(*o_.ts_above), t.silent_interval_k),
        fmt::format("give --silent-interval {} to lec (or set the controller's Silent INT to "
                    "{}), then run lec doctor again with it to check Td",
                    k_min, t.silent_interval_k));
  }
  if (o_.ts_above) return;  // Ts and Td add up in a round trip: Td needs Ts known first
  const Duration td = turnaround - t.silent_interval() - modbus::LineTiming::kProcessing;
  const double td_ms = std::max(0.0, ms(td));
  const std::string saw = fmt::format(
      "the fastest reply came {:.1f} ms after the query's end (Ts + T0 + Td), lec assumes {:.1f} "
      "ms (Ts {:.2f} ms = Silent INT {} x 3.5 chars, T0 4 ms, Td {:.0f} ms)",
      ms(turnaround), ms(assumed), ms(t.silent_interval()), t.silent_interval_k, ms(t.delay_td));
  const Duration tolerance = std::chrono::milliseconds(2);
  if (turnaround > assumed + tolerance) {
    const double rounded = std::round(td_ms);
    add("timing", Severity::Warning, saw,
        fmt::format("the controller answers later than lec assumes: its Min Resp delay (Td) is "
                    "about {:.0f} ms, or its Silent INT is above {} (the two add up; lec's "
                    "timeouts and pacing use them)",
                    rounded, t.silent_interval_k),
        fmt::format("give --td {:.0f}ms to lec (or set the controller's Min Resp delay back "
                    "to {:.0f} ms)",
                    rounded, ms(t.delay_td)));
  } else if (turnaround + tolerance < assumed) {
    add("timing", Severity::Info, saw,
        fmt::format("the controller answers sooner than lec assumes: its Min Resp delay (Td) is "
                    "about {:.0f} ms",
                    td_ms),
        fmt::format("optional: --td {:.0f}ms makes lec's reply timeout tighter",
                    std::round(td_ms)));
  } else {
    add("timing", Severity::Info, saw,
        "the controller's response time matches the manual's Tx with lec's Ts and Td", "");
  }
}

void Builder::line_quality() {
  const auto& b = o_.burst;
  if (b.exchanges == 0) return;
  // Duplicate IDs: replies garbled though they carry the ID asked, on one ID
  // far more than on the others (noise hits every ID alike); with one ID
  // only, on an otherwise quiet line.
  auto garbled_rate = [&](uint8_t id) {
    const auto g = b.per_id_garbled.find(id);
    const int garbled = g == b.per_id_garbled.end() ? 0 : g->second;
    return static_cast<double>(garbled) / std::max(1, b.per_id_exchanges.at(id));
  };
  std::vector<uint8_t> dup;
  for (const auto& [id, n] : b.per_id_exchanges) {
    if (n < 5 || garbled_rate(id) < 0.1) continue;
    // Another master heard asking this ID: its queries (our query, byte for
    // byte, to the same ID) and the replies to them land in our windows
    // with the ID in their first byte. That master is the finding, not a
    // second controller (a reviewer's case on the virtual line).
    if (std::ranges::find(o_.foreign_query_ids, id) != o_.foreign_query_ids.end()) continue;
    double others = 0;
    for (const auto& [other, m] : b.per_id_exchanges)
      if (other != id && m >= 5) others = std::max(others, garbled_rate(other));
    const bool alone = b.per_id_exchanges.size() == 1;
    const bool quiet = b.noise_bytes * 4 <= static_cast<uint64_t>(b.exchanges);
    if (alone ? quiet : others * 4 <= garbled_rate(id)) dup.push_back(id);
  }
  if (!dup.empty()) {
    for (uint8_t id : dup) {
      const int n = b.per_id_exchanges.at(id);
      const int g = b.per_id_garbled.at(id);
      add("duplicate-id", Severity::Error,
          fmt::format("{} of {} replies from ID {} garbled, with ID {} in their first byte{}", g, n,
                      id, id,
                      b.per_id_exchanges.size() > 1 ? ", the other IDs' replies sound"
                                                    : ", on an otherwise quiet line"),
          fmt::format("two controllers answer ID {}: their replies collide on the line", id),
          fmt::format("give one of them another ID (controller setting software, or its ID "
                      "switch), then run lec doctor again"),
          id);
    }
    return;
  }
  const int bad = b.crc + b.framing;
  const double rate = 1000.0 * bad / b.exchanges;
  const std::string late =
      b.late > 0 ? fmt::format(", {} whole but late (after Tx + margin)", b.late) : "";
  const std::string saw = fmt::format(
      "{} exchanges: {} CRC errors, {} framing errors, {} timeouts{}, {} noise bytes (per 1000 "
      "exchanges: {} CRC, {} framing, {} timeouts, {} noise bytes)",
      b.exchanges, b.crc, b.framing, b.timeouts, late, b.noise_bytes, per_k(b.crc, b.exchanges),
      per_k(b.framing, b.exchanges), per_k(b.timeouts, b.exchanges),
      per_k(static_cast<int>(b.noise_bytes), b.exchanges));
  if (bad == 0 && b.timeouts == 0 && b.noise_bytes == 0 && b.late == 0) {
    add("line-quality", Severity::Info, saw, "the line is clean", "");
    return;
  }
  if (bad == 0 && b.noise_bytes == 0 && b.timeouts * 20 <= b.exchanges) {
    // Late replies on a line that garbles nothing: the controller, the
    // adapter or the host was slow (CI, stop 40: a twin on a host busy with
    // other tests answered 7 of 83 queries late, each whole). Not the
    // cabling: what to change is the reply window.
    if (b.late * 5 <= b.exchanges) {
      add("line-quality", Severity::Info, saw,
          "the line garbles nothing; a few replies came after the reply window (Tx + margin), "
          "which lec's retries cover",
          "if it persists: a larger --reply-margin");
    } else {
      add("line-quality", Severity::Warning, saw,
          "the line garbles nothing, but many replies come after the reply window (Tx + "
          "margin): lec times them out and asks again, at a cost in rate",
          "give a larger --reply-margin (e.g. --reply-margin 100ms) to every lec command; if "
          "the controller's Min Resp delay (Td) is long, --td");
    }
    return;
  }
  const bool severe = rate >= 200 || b.timeouts * 5 >= b.exchanges;
  add("line-quality", severe ? Severity::Error : Severity::Warning, saw,
      severe ? "the line loses or garbles many frames: lec's retries cannot hide it"
             : "the line garbles some frames: lec's retries recover them, at a cost in rate",
      "likely causes, in order: termination (120 ohm across A/B at both ends of the line, "
      "nowhere else); bias (fail-safe resistors holding the idle line, usually in the adapter); "
      "ground (a signal ground wire between adapter and controllers); cable (twisted pair, "
      "shielded, no long stubs, away from motor cables)");
}

void Builder::controllers() {
  for (const auto& c : o_.controllers) {
    const std::string who =
        fmt::format("ID {}{}", c.id, c.name.empty() ? "" : fmt::format(" ({})", c.name));
    if (!c.read_error.empty()) {
      add("controller", Severity::Warning,
          fmt::format("{}: its state could not be read: {}", who, c.read_error),
          "it answers, but not reliably enough to read its flags", "", c.id);
      continue;
    }
    std::string fixed;
    for (const auto& f : c.fixed) fixed += (fixed.empty() ? "; --fix: " : ", ") + f;
    if (!c.alarms.empty()) {
      std::string list;
      for (uint8_t a : c.alarms)
        list += fmt::format("{}alarm {}: {}", list.empty() ? "" : "; ", a, lec::alarm_meaning(a));
      const bool resettable = std::all_of(c.alarms.begin(), c.alarms.end(), lec::alarm_resettable);
      add("controller", Severity::Warning, fmt::format("{}: {}{}", who, list, fixed),
          "the controller stops and refuses to move while an alarm is active",
          resettable ? fmt::format("clear it: {} (or lec doctor --fix)", lec_cmd(o_, c.id, "reset"))
                     : lec::alarm_clear_hint(c.alarms),
          c.id);
    }
    if (!c.alarm_check.empty()) {
      add("controller", Severity::Warning, fmt::format("{}: {}", who, c.alarm_check),
          "X4F ALARM alone decides nothing: lec6 checks it against the alarm code (D0380) and "
          "motion, and they disagree",
          "give lec the polarity the message names: lec --alarm-polarity VALUE … (or "
          "LEC_ALARM_POLARITY=VALUE)",
          c.id);
    }
    std::vector<std::string> steps;
    std::vector<std::string> state;
    state.push_back(c.serial_mode ? "serial mode (Y30 = 1)" : "parallel mode (Y30 = 0)");
    state.push_back(c.servo_on ? (c.svre ? "servo on and ready" : "servo on, not ready")
                               : "servo off");
    state.push_back(c.homed ? "homed (SETON)" : "not homed");
    if (c.estop) state.push_back("EMG stop active (ESTOP)");
    // Never done by --fix unless named: a controller in parallel mode may be its PLC's.
    if (!c.serial_mode)
      steps.push_back(
          fmt::format("{} (or lec doctor --fix --serial-ids {}; only if no PLC drives "
                      "it through parallel I/O)",
                      lec_cmd(o_, c.id, "serial on"), c.id));
    if (!c.servo_on) steps.push_back(lec_cmd(o_, c.id, "servo on"));
    if (!c.homed) steps.push_back(lec_cmd(o_, c.id, "home"));
    std::string joined;
    for (std::size_t i = 0; i < state.size(); ++i) joined += (i ? ", " : "") + state[i];
    std::string todo;
    for (std::size_t i = 0; i < steps.size(); ++i) todo += (i ? " && " : "") + steps[i];
    if (c.estop) todo = "release the EMG stop; " + todo;
    if (!c.alarms.empty()) {
      steps.insert(steps.begin(), "reset");
      todo = "clear the alarm (above)" + (todo.empty() ? std::string() : ", then " + todo);
    }
    add("controller", Severity::Info,
        fmt::format("{}: {}{}", who, joined, c.alarms.empty() ? fixed : ""),
        steps.empty() ? "ready to move" : "not ready to move yet (nothing was moved)",
        steps.empty() ? std::string() : "get it ready: " + todo, c.id);
  }
}

}  // namespace

std::string join_ids(const std::vector<uint8_t>& ids) {
  std::string out;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (i) out += i + 1 == ids.size() ? " and " : ", ";
    out += std::to_string(ids[i]);
  }
  return out;
}

std::string_view to_string(Severity s) noexcept {
  switch (s) {
    case Severity::Info:
      return "info";
    case Severity::Warning:
      return "warning";
    case Severity::Error:
      return "error";
  }
  return "?";
}

std::string_view to_string(Health h) noexcept {
  switch (h) {
    case Health::Healthy:
      return "healthy";
    case Health::Degraded:
      return "degraded";
    case Health::Broken:
      return "broken";
  }
  return "?";
}

void account_too_fast(BurstStats& b, int too_fast) {
  // A late reply needs a query that went unanswered in its own window: a
  // line whose replies are late has as many timeouts as too-fast replies.
  // A port no wire paces has too-fast replies and (nearly) no timeouts; a
  // busy host delays some of its replies past the wire time (good ones).
  if (too_fast > 0 && too_fast * 2 >= too_fast + b.good && b.timeouts * 10 <= b.exchanges) {
    b.unpaced = true;
    b.good += too_fast;
  } else {
    b.timeouts += too_fast;
  }
}

Report diagnose(const Observations& obs) {
  Builder b(obs);
  if (obs.gateway) {
    b.gateway();
  } else {
    b.baud_and_ids();
    b.echo();
    b.other_master();
    if (obs.found_baud) {
      // With another master on the line, its replies arrive in our windows:
      // round trips say nothing then.
      if (obs.foreign_query_ids.empty()) {
        b.usb_latency();
        b.timing();
      }
      b.line_quality();
    }
  }
  b.controllers();
  return b.take();
}

}  // namespace lec6::client::doctor
