// lec doctor: commission an RS485 line. The probes (I/O) are here and in
// doctor_line.cpp; the judgement is client/doctor (sans-I/O).

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <thread>

#include "cli/app.hpp"
#include "cli/doctor_line.hpp"
#include "cli/sim_args.hpp"
#include "lec6/client/doctor.hpp"
#include "lec6/client/errors.hpp"
#include "lec6/lec/alarm_check.hpp"
#include "lec6/lec/alarms.hpp"

namespace lec6::cli {
namespace {

namespace dx = client::doctor;
using doctor_line::kStateReplyBytes;
using doctor_line::LineProbe;
using doctor_line::state_query;
using std::chrono::milliseconds;
using std::chrono::seconds;

struct DoctorArgs {
  bool fix = false;
  std::string ids = "1-32";
  std::string serial_ids;  // the IDs --fix may put into serial mode (issue 31 rule 7)
};

// What --fix may change. Serial mode only on the IDs named: a controller
// driven through parallel I/O ignores its PLC's HOLD and RESET once Y30 = 1
// (manual, footnote on serial mode), so the doctor never takes one away
// from its PLC unless told (the report names the command that would).
struct Fix {
  bool on = false;
  std::vector<uint8_t> serial_ids;
  bool may_set_serial(uint8_t id) const {
    return on && std::find(serial_ids.begin(), serial_ids.end(), id) != serial_ids.end();
  }
};

// Every check's deadline (the whole run stays within the sum, about 25 s at
// worst: six baud rates of 32 IDs at 9600-like windows, then the rest).
constexpr Duration kListen = milliseconds(500);
constexpr Duration kScanMargin = milliseconds(20);  // beyond Tx: a USB adapter's latency lump
constexpr Duration kSearchBudget = seconds(18);
constexpr Duration kBurstBudget = seconds(3);
constexpr int kBurstExchanges = 200;
constexpr int kNoisyRescans = 4;

std::string port_text(const GlobalOptions& g) {
  if (!g.port.empty()) return g.port;
  if (const char* env = std::getenv("LEC_PORT"); env && *env) return env;
  throw UsageError(
      "lec doctor: no port given: use --port /dev/ttyUSB0 (lec ports lists this machine's serial "
      "ports), or set LEC_PORT");
}

// The line's options as every lec command's (line_port_options), at the baud
// and echo handling the doctor is trying.
twin::PortOptions port_options(const GlobalOptions& g, uint32_t baud, bool discard_echo) {
  twin::PortOptions po = line_port_options(g);
  po.baud = baud;
  po.discard_echo = discard_echo;
  po.interrupted = [] { return g_interrupted.load(); };
  return po;
}

void note_foreign(dx::Observations& obs, const modbus::Bytes& heard) {
  obs.listened += kListen;
  obs.foreign_bytes += heard.size();
  for (uint8_t id : dx::foreign_queries(heard)) obs.foreign_query_ids.push_back(id);
}

// 1. Baud and IDs: the first rate where something answers.
void search(const transport::PortSpec& spec, const GlobalOptions& g,
            const std::vector<uint8_t>& ids, dx::Observations& obs) {
  std::vector<uint32_t> order{g.baud};
  for (uint32_t b : modbus::kBaudRates)
    if (b != g.baud) order.push_back(b);
  const TimePoint until = SteadyClock{}.now() + kSearchBudget;
  // First pass: short windows. Nothing anywhere: a second pass with the full
  // reply margin (a slow converter, a busy host), within the same budget.
  for (int pass = 0; pass < 2; ++pass) {
    const Duration window_margin = pass == 0 ? kScanMargin : std::max(kScanMargin, g.reply_margin);
    if (pass == 1 && window_margin == kScanMargin) break;
    for (uint32_t baud : order) {
      if (g_interrupted) break;
      if (SteadyClock{}.now() >= until) {
        obs.budget_ran_out = true;
        break;
      }
      LineProbe p(spec, port_options(g, baud, false));
      // 6. Another master: listen before sending anything.
      if (obs.bauds.empty()) note_foreign(obs, p.listen(kListen));
      dx::BaudProbe bp;
      bp.baud = baud;
      auto scan = [&](Duration margin) {
        bp = {};
        bp.baud = baud;
        for (uint8_t id : ids) {
          if (g_interrupted || SteadyClock{}.now() >= until) break;
          const auto h = p.exchange(state_query(id), kStateReplyBytes, margin);
          bp.echo = bp.echo || h.result.echo;
          bp.stray_bytes += h.result.noise_bytes;
          switch (h.result.kind) {
            case dx::ReplyKind::Good:
            case dx::ReplyKind::Exception:
              bp.answering.push_back(id);
              break;
            case dx::ReplyKind::Crc:
            case dx::ReplyKind::Framing:
              bp.garbled.push_back(id);
              break;
            default:
              break;
          }
        }
      };
      scan(window_margin);
      // Noise on the line at the rate the user gave (or lec's default), and
      // no answer: a garbled query gets no reply at all, so one scan can miss
      // a controller that is there. kNoisyRescans more at that rate only (a
      // noisy line is noisy at every rate: asking again everywhere would cost
      // the search's budget). At half the exchanges lost, one scan misses
      // the controller every other time, five scans about once in 32 (and
      // the rescan with the full reply margin below is one more).
      for (int again = 0; again < kNoisyRescans && baud == order.front() && bp.answering.empty() &&
                          (bp.stray_bytes > 0 || !bp.garbled.empty());
           ++again) {
        const dx::BaudProbe before = bp;
        scan(window_margin);
        bp.stray_bytes += before.stray_bytes;
        for (uint8_t id : before.garbled)
          if (std::find(bp.garbled.begin(), bp.garbled.end(), id) == bp.garbled.end())
            bp.garbled.push_back(id);
        std::sort(bp.garbled.begin(), bp.garbled.end());
        std::erase_if(bp.garbled, [&](uint8_t id) {
          return std::find(bp.answering.begin(), bp.answering.end(), id) != bp.answering.end();
        });
        bp.echo = bp.echo || before.echo;
      }
      // Bytes but no answer: perhaps replies later than the short window (a
      // slow converter, a busy host): once more with the full reply margin.
      Duration asked_with = window_margin;
      if (pass == 0 && bp.answering.empty() && (bp.stray_bytes > 0 || !bp.garbled.empty()) &&
          g.reply_margin > kScanMargin) {
        scan(g.reply_margin);
        asked_with = g.reply_margin;
      }
      // Bytes heard while some IDs answered and others did not: a reply later
      // than the short window lands in the next exchange as stray bytes (a
      // controller with a longer Td, or a busy host: a clean make test run
      // missed a duplicate ID so in two runs). The silent IDs once more with
      // the full reply margin. (The last ID's late reply has no next exchange
      // to land in: not seen so.)
      if (!bp.answering.empty() && bp.stray_bytes > 0 && g.reply_margin > asked_with) {
        for (uint8_t id : ids) {
          if (g_interrupted || SteadyClock{}.now() >= until) break;
          if (std::ranges::binary_search(bp.answering, id) ||
              std::ranges::find(bp.garbled, id) != bp.garbled.end())
            continue;
          const auto k = p.exchange(state_query(id), kStateReplyBytes, g.reply_margin).result.kind;
          if (dx::answered(k)) {
            bp.answering.insert(std::ranges::upper_bound(bp.answering, id), id);
          } else if (k == dx::ReplyKind::Crc || k == dx::ReplyKind::Framing) {
            bp.garbled.push_back(id);
          }
        }
      }
      if (!bp.answering.empty() || !bp.garbled.empty()) {
        // A garbled reply carried its ID at this rate: that controller is
        // there (a collision or noise); ask it again, so the later checks
        // include it. Also when no other answered: on a noisy line with one
        // controller its one scan query may be garbled, and the doctor said
        // "nothing answers at any baud" (seen once in a test run).
        std::vector<uint8_t> still;
        for (uint8_t id : bp.garbled) {  // Crc, Framing: a reply that carried the ID
          bool ok = false;
          bool again = false;  // garbled again: not noise that began with its ID
          for (int i = 0; i < 3 && !ok && !g_interrupted && SteadyClock{}.now() < until; ++i) {
            const auto k =
                p.exchange(state_query(id), kStateReplyBytes, std::max(kScanMargin, g.reply_margin))
                    .result.kind;
            ok = dx::answered(k);
            again = again || k == dx::ReplyKind::Crc || k == dx::ReplyKind::Framing;
          }
          if (ok) {
            bp.answering.insert(std::upper_bound(bp.answering.begin(), bp.answering.end(), id), id);
          } else {
            still.push_back(id);
            if (again) bp.garbled_again.push_back(id);
          }
        }
        bp.garbled = still;
      }
      obs.echo_seen = obs.echo_seen || bp.echo;
      if (pass == 1) {  // the second look replaces the first at this rate
        std::erase_if(obs.bauds, [&](const dx::BaudProbe& b) { return b.baud == baud; });
      }
      obs.bauds.push_back(bp);
      if (!bp.answering.empty()) {
        obs.found_baud = baud;
        if (obs.bauds.size() > 1) note_foreign(obs, p.listen(kListen));  // at the right rate too
        return;
      }
    }
  }
}

// 5, 7, 4. A short burst of reads, round robin over the IDs that answered.
void burst(const transport::PortSpec& spec, const GlobalOptions& g, const std::vector<uint8_t>& ids,
           dx::Observations& obs) {
  LineProbe p(spec, port_options(g, *obs.found_baud, false));
  auto& b = obs.burst;
  b.query_bytes = state_query(1).size();
  b.reply_bytes = kStateReplyBytes;
  const TimePoint until = SteadyClock{}.now() + kBurstBudget;
  // No reply can be complete sooner: one that is was late for the query before.
  const Duration fastest = p.timing().wire_time(b.query_bytes) +
                           p.timing().wire_time(b.reply_bytes) + modbus::LineTiming::kProcessing;
  int too_fast = 0;
  for (int i = 0; i < kBurstExchanges && SteadyClock{}.now() < until && !g_interrupted; ++i) {
    const uint8_t id = ids[static_cast<std::size_t>(i) % ids.size()];
    // 0-16 ms more between exchanges, spread evenly: a USB adapter's latency
    // timer ticks on its own clock; paced at one rate, every reply would
    // meet it at the same phase and the lumps would look like a longer Td.
    std::this_thread::sleep_for(milliseconds((i * 7) % 17));
    auto h = p.exchange(state_query(id), kStateReplyBytes, g.reply_margin);
    ++b.exchanges;
    ++b.per_id_exchanges[id];
    const auto whole = [](dx::ReplyKind k) { return dx::answered(k); };
    const bool answered = whole(h.result.kind);
    if (h.result.kind == dx::ReplyKind::None || h.result.kind == dx::ReplyKind::Garbage ||
        h.result.kind == dx::ReplyKind::Framing) {
      // No whole reply in its window (nothing, or only its first bytes: a
      // USB adapter hands replies over in lumps): listen one more margin. A
      // whole reply then is late, not lost or garbled (a slow controller,
      // adapter or host: the reply window is what to change, not the
      // cabling); either way it must not answer the next query.
      const modbus::Bytes more = p.listen(g.reply_margin);
      h.bytes.insert(h.bytes.end(), more.begin(), more.end());
      const auto late = dx::classify_exchange(state_query(id), h.bytes);
      if (whole(late.kind)) {
        ++b.late;
        b.noise_bytes += late.noise_bytes;
        continue;
      }
      // Late and garbled (a collision that came after the window): garbled,
      // as it would have been in time, not a timeout.
      if (late.kind == dx::ReplyKind::Crc || late.kind == dx::ReplyKind::Framing) h.result = late;
    } else if (!answered || h.round_trip < fastest) {
      // A late reply still on its way must not answer the next query.
      std::this_thread::sleep_for(g.reply_margin);
    }
    std::size_t noise = h.result.noise_bytes;
    if (answered && h.round_trip < fastest) {
      // The previous query's late reply, then ours: our reply after it is
      // no noise (a fast twin on a loaded host, make test: 19 "noise" bytes
      // a time, and the cabling blamed).
      const auto rest = std::span<const uint8_t>(h.bytes).subspan(
          std::min(h.bytes.size(), h.result.reply_offset + h.result.reply_bytes));
      const auto ours = dx::classify_exchange(state_query(id), rest);
      if (whole(ours.kind) && ours.reply_offset == 0) noise -= std::min(noise, ours.reply_bytes);
    }
    b.noise_bytes += noise;
    switch (h.result.kind) {
      case dx::ReplyKind::Good:
      case dx::ReplyKind::Exception:
        if (h.round_trip < fastest) {
          // The previous query's late reply (ours came after the window), or
          // a line that no wire paces: told apart below, over the burst.
          ++too_fast;
          break;
        }
        ++b.good;
        b.round_trips.push_back(h.round_trip);
        break;
      case dx::ReplyKind::Crc:
        ++b.crc;
        ++b.per_id_garbled[id];
        break;
      case dx::ReplyKind::Framing:
        ++b.framing;
        ++b.per_id_garbled[id];
        break;
      default:
        ++b.timeouts;
        break;
    }
  }
  dx::account_too_fast(b, too_fast);
}

// 4. Silent INT: does a query in two parts, a gap longer than lec's Ts
// apart, still get an answer? Then the controller's Ts is longer: bracket it.
void probe_silent_interval(const transport::PortSpec& spec, const GlobalOptions& g, uint8_t id,
                           dx::Observations& obs) {
  LineProbe p(spec, port_options(g, *obs.found_baud, false));
  const Duration ts = p.timing().silent_interval();
  // Two of three answered: a late wake-up (ours, or a twin's on a busy host)
  // can close or stretch a gap once, rarely twice.
  auto one_frame = [&](Duration gap) {
    int answered = 0;
    for (int i = 0; i < 3 && answered < 2 && answered + (3 - i) >= 2; ++i) {
      const auto k = p.exchange(state_query(id), kStateReplyBytes, g.reply_margin, gap).result.kind;
      answered += dx::answered(k);
    }
    return answered >= 2;
  };
  // Far enough above Ts that timer and adapter jitter cannot close the gap.
  Duration lo = std::max<Duration>(ts * 3, milliseconds(2));
  obs.ts_gap_tried = lo;
  if (!one_frame(lo)) return;
  // Bracket: double until a gap ends the frame (Ts is at most 100 x 3.5 chars).
  const Duration ts_max = ts * 100 / static_cast<int64_t>(g.silent_interval_k);
  Duration hi = lo * 2;
  while (hi <= ts_max && one_frame(hi)) {
    lo = hi;
    hi = hi * 2;
  }
  for (int i = 0; i < 3; ++i) {
    const Duration mid = (lo + hi) / 2;
    if (one_frame(mid)) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  obs.ts_above = lo;
}

// 2. Echo: does echo discard make transactions work?
bool echo_fix_works(const transport::PortSpec& spec, const GlobalOptions& g, uint8_t id,
                    uint32_t baud) {
  try {
    auto port = twin::open_port(spec, port_options(g, baud, true));
    client::Client c(port->master(), {.id = id, .retries = 2});
    c.read_state();
    return true;
  } catch (const client::TransportError&) {
    return false;
  } catch (const client::LinkError& e) {
    if (e.kind() == client::LinkErrorKind::PortUnavailable) throw;
    return false;
  }
}

// 8. Each controller's state, read only (--fix: serial mode on, alarms reset).
dx::ControllerState read_controller(client::Client& c, client::Actuator& axis, uint8_t id,
                                    const Fix& fix) {
  // ALARM is never decided from X4F alone (issue 33): checked against the code below.
  dx::ControllerState st;
  st.id = id;
  c.set_id(id);
  try {
    auto controls = c.read_controls();
    if (fix.may_set_serial(id) && !controls.serial_mode) {
      axis.set_serial_mode(true);
      controls = c.read_controls();
      if (controls.serial_mode) st.fixed.push_back("serial mode on (Y30)");
    }
    auto flags = c.read_flags();
    auto alarms = axis.active_alarms(flags);
    std::vector<uint8_t> left;  // resettable codes a RESET left (lec::alarm_after_reset)
    if (fix.on && !alarms.empty() &&
        std::all_of(alarms.begin(), alarms.end(), lec::alarm_resettable) && controls.serial_mode) {
      left = axis.reset_alarms();
      for (uint8_t a : alarms)
        if (std::find(left.begin(), left.end(), a) == left.end())
          st.fixed.push_back(fmt::format("alarm {} cleared (RESET)", a));
      flags = c.read_flags();
      alarms = axis.active_alarms(flags);
    }
    st.serial_mode = controls.serial_mode;
    st.servo_on = controls.test(lec::Coil::SVON);
    st.svre = flags.svre();
    st.homed = flags.seton();
    st.estop = flags.estop();
    const auto judged =
        lec::judge_alarm(flags, c.read_alarms().groups[0], c.options().alarm_polarity);
    st.alarms = judged.codes;
    st.alarm_check = judged.disagreement;
    if (st.alarm_check.empty() && !left.empty() && judged.active)
      st.alarm_check = lec::alarm_after_reset(left, c.options().alarm_polarity);
    try {
      st.name = c.read_name().text;
    } catch (const client::TransportError&) {
    } catch (const client::ControllerException&) {
    }
  } catch (const client::TransportError& e) {
    st.read_error = e.what();
  } catch (const client::ControllerException& e) {
    st.read_error = e.what();
  }
  return st;
}

void read_controllers(const transport::PortSpec& spec, const twin::PortOptions& po,
                      const std::vector<uint8_t>& ids, const Fix& fix, dx::Observations& obs,
                      const GlobalOptions& g) {
  auto port = twin::open_port(spec, po);
  client::Client c(
      port->master(),
      {.id = ids.front(),
       .retries = 2,
       .alarm_polarity =
           lec::parse_alarm_polarity(g.alarm_polarity).value_or(lec::AlarmPolarity::ActiveHigh)});
  client::Actuator axis(c);
  for (uint8_t id : ids) {
    if (g_interrupted) break;
    obs.controllers.push_back(read_controller(c, axis, id, fix));
  }
}

// Through a gateway (tcp://, e.g. lec serve): only the controllers.
void through_gateway(const transport::PortSpec& spec, const GlobalOptions& g,
                     const std::vector<uint8_t>& ids, const Fix& fix, dx::Observations& obs) {
  obs.gateway = true;
  auto po = port_options(g, g.baud, false);
  auto port = twin::open_port(spec, po);
  client::Client c(port->master(), {.id = ids.front(), .retries = 0});
  dx::BaudProbe bp;
  const TimePoint until = SteadyClock{}.now() + kSearchBudget;
  for (uint8_t id : ids) {
    if (g_interrupted || SteadyClock{}.now() >= until) break;
    c.set_id(id);
    try {
      c.read_flags();
      bp.answering.push_back(id);
    } catch (const client::TransportError&) {
    } catch (const client::ControllerException&) {
    }
  }
  obs.bauds.push_back(bp);
  if (!bp.answering.empty()) read_controllers(spec, po, bp.answering, fix, obs, g);
}

nlohmann::json to_json(const dx::Observations& obs, const dx::Report& r) {
  nlohmann::json j;
  j["port"] = obs.port;
  j["health"] = dx::to_string(r.health);
  j["baud"] = obs.found_baud ? nlohmann::json(*obs.found_baud) : nlohmann::json();
  j["ids"] = obs.bauds.empty() || (!obs.found_baud && !obs.gateway)
                 ? nlohmann::json::array()
                 : nlohmann::json(obs.bauds.back().answering);
  j["echo"] = obs.echo_seen;
  j["findings"] = nlohmann::json::array();
  for (const auto& f : r.findings) {
    nlohmann::json fj{{"check", f.check},
                      {"severity", dx::to_string(f.severity)},
                      {"saw", f.saw},
                      {"means", f.means},
                      {"todo", f.todo}};
    fj["id"] = f.id ? nlohmann::json(*f.id) : nlohmann::json();
    j["findings"].push_back(fj);
  }
  const auto& b = obs.burst;
  j["burst"] = {{"exchanges", b.exchanges},     {"good", b.good},         {"crc", b.crc},
                {"framing", b.framing},         {"timeouts", b.timeouts}, {"late", b.late},
                {"noise_bytes", b.noise_bytes}, {"unpaced", b.unpaced}};
  return j;
}

// On a terminal: each finding wrapped at its width, continuation lines
// indented under the text; piped: one line per finding.
std::string wrap(const std::string& text, std::size_t indent) {
  winsize ws{};
  if (!::isatty(STDOUT_FILENO) || ::ioctl(STDOUT_FILENO, TIOCGWINSZ, &ws) != 0 || ws.ws_col < 60)
    return text;
  const std::size_t width = ws.ws_col;
  std::string out;
  std::size_t col = 0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t end = text.find(' ', pos);
    if (end == std::string::npos) end = text.size();
    const std::string word = text.substr(pos, end - pos);
    if (col > indent && col + 1 + word.size() > width) {
      out += "\n" + std::string(indent, ' ');
      col = indent;
    } else if (pos > 0) {
      out += ' ';
      ++col;
    }
    out += word;
    col += word.size();
    pos = end + 1;
  }
  return out;
}

void print_report(const dx::Observations& obs, const dx::Report& r, Duration took) {
  fmt::print("lec doctor: {}{}\n", obs.port, obs.gateway ? " (through a Modbus TCP gateway)" : "");
  for (const auto& f : r.findings) {
    const char* tag = f.severity == dx::Severity::Error     ? "BROKEN "
                      : f.severity == dx::Severity::Warning ? "WARN   "
                                                            : "ok     ";
    const std::string line = fmt::format("  {}{:<13} {} -- {}{}", tag, f.check, f.saw, f.means,
                                         f.todo.empty() ? "" : ". Do: " + f.todo);
    fmt::print("{}\n", wrap(line, 23));
  }
  fmt::print("{} ({:.1f} s, nothing was moved)\n", dx::to_string(r.health),
             std::chrono::duration<double>(took).count());
}

void run_doctor(Session& s, const DoctorArgs& a) {
  const GlobalOptions& g = s.options();
  const std::string text = port_text(g);
  const auto spec = transport::parse_port_spec(text);
  if (spec.kind == transport::PortKind::Sim) {
    throw UsageError(
        "lec doctor probes a line: give --port /dev/ttyUSB0 (or the --pty of a lec sim twin); "
        "the in-process twin has no line to check");
  }
  auto id_list = sim_args::parse_ids(a.ids);
  const Fix fix{a.fix,
                a.serial_ids.empty() ? std::vector<uint8_t>{} : sim_args::parse_ids(a.serial_ids)};
  if (!a.serial_ids.empty() && !a.fix)
    throw UsageError("--serial-ids names what --fix may put into serial mode: give --fix too");
  const TimePoint start = SteadyClock{}.now();

  dx::Observations obs;
  obs.port = text;
  obs.id_range = a.ids;
  obs.echo_option = g.echo;
  obs.fix = a.fix;
  obs.assumed.baud = g.baud;
  obs.assumed.silent_interval_k = g.silent_interval_k;
  obs.assumed.delay_td = g.delay_td;

  if (spec.kind == transport::PortKind::Tcp) {
    through_gateway(spec, g, id_list, fix, obs);
  } else {
    search(spec, g, id_list, obs);
    if (obs.found_baud) {
      obs.assumed.baud = *obs.found_baud;
      const auto& found = obs.bauds.back().answering;
      if (obs.echo_seen)
        obs.echo_fix_works = echo_fix_works(spec, g, found.front(), *obs.found_baud);
      // The burst asks the IDs whose replies were garbled every time asked
      // too: they are there, and two controllers on one ID whose every reply
      // collides are the duplicate the burst must see. (Not an ID garbled
      // once and silent since: noise that began with its ID, a reviewer
      // showed, would make a phantom of it.)
      std::vector<uint8_t> asked = found;
      for (uint8_t id : obs.bauds.back().garbled_again) asked.push_back(id);
      std::ranges::sort(asked);
      burst(spec, g, asked, obs);
      // Not with another master on the line: its replies would answer for ours.
      if (obs.foreign_query_ids.empty()) probe_silent_interval(spec, g, found.front(), obs);
      if (spec.kind == transport::PortKind::Serial) {
        // LEC6_SYSFS_ROOT: a stand-in sysfs tree (the tests' USB adapter).
        const char* root = std::getenv("LEC6_SYSFS_ROOT");
        if (auto t = doctor_line::read_latency_timer(spec.device, root && *root ? root : "/sys")) {
          obs.latency_timer_ms = t->ms;
          obs.latency_timer_path = t->file.string();
          if (a.fix && t->ms > 1) obs.latency_fixed = doctor_line::set_latency_timer_1ms(*t);
        }
      }
      read_controllers(spec, port_options(g, *obs.found_baud, obs.echo_seen || g.echo), found, fix,
                       obs, g);
    }
  }
  const dx::Report r = dx::diagnose(obs);
  if (s.json()) {
    print_json(to_json(obs, r));
  } else {
    print_report(obs, r, SteadyClock{}.now() - start);
  }
  if (g_interrupted) throw client::Cancelled("interrupted");
  if (r.health == dx::Health::Broken)
    throw CommandFailed(kBroken, "the line is broken (see above)");
  if (r.health == dx::Health::Degraded)
    throw CommandFailed(kDegraded, "the line works, degraded (see above)");
}

}  // namespace

void add_doctor_command(CLI::App& app, Session& session) {
  auto a = std::make_shared<DoctorArgs>();
  auto* cmd = app.add_subcommand(
      "doctor",
      "Diagnose the line: baud and IDs, echo, USB latency, timing, noise, another master, "
      "duplicate IDs, each controller's state; says what to do (never moves anything)");
  cmd->footer(
      "Example: lec doctor --port /dev/ttyUSB0 (no other option needed; --json for data; "
      "docs/doctor.md).\n"
      "Checks, each with its own deadline (a full run takes seconds, under 30 s at worst): the "
      "baud rate (9600 ... 230400, the first that answers, starting at --baud) and the IDs that "
      "answer; a 2-wire adapter's echo (and that --echo fixes it); the USB latency timer "
      "(sysfs); the response time against the manual's Tx (Td, Silent INT); CRC/framing "
      "errors and noise bytes in a short burst; another master's traffic heard before sending; "
      "duplicate IDs; each controller's serial mode (Y30), servo, homing, alarms and name, with "
      "the lec command that gets it ready.\n"
      "Through lec serve (--port tcp://HOST:1502): only the controllers' state.\n"
      "Exit codes: 0 healthy, 7 degraded (works, but slower or less reliable than it could be), "
      "8 broken (something does not work); 2 usage, 3 port missing or busy.");
  cmd->add_flag("--fix", a->fix,
                "Apply the safe fixes: clear alarms that RESET clears, USB latency timer to 1 ms "
                "(needs permission); serial mode (Y30) only on --serial-ids. Never a move.");
  cmd->add_option("--serial-ids", a->serial_ids,
                  "With --fix: the IDs it may put into serial mode (Y30 = 1), e.g. 1,3. A "
                  "controller in serial mode ignores its PLC's parallel I/O (HOLD, RESET "
                  "included): name only those no PLC drives");
  cmd->add_option("--ids", a->ids, "IDs to scan, e.g. 1-32 or 1,3,5")->capture_default_str();
  cmd->callback([&session, a] { run_doctor(session, *a); });
}

}  // namespace lec6::cli
