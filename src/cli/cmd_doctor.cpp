// lec doctor: commission an RS485 line. The probes (I/O) are here and in
// doctor_line.cpp; the judgement is client/doctor (sans-I/O).

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <thread>

#include "cli/app.hpp"
#include "cli/doctor_line.hpp"
#include "cli/doctor_probes.hpp"
#include "cli/sim_args.hpp"
#include "lec6/client/doctor.hpp"
#include "lec6/client/errors.hpp"
#include "lec6/lec/alarm_check.hpp"
#include "lec6/lec/alarms.hpp"

namespace lec6::cli {
namespace {

namespace dx = client::doctor;

struct DoctorArgs {
  bool fix = false;
  std::string ids = "1-32";
  std::string serial_ids;  // the IDs --fix may put into serial mode (issue 31 rule 7)
};

using doctor_probes::Fix;
using doctor_probes::kSearchBudget;

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

// The probes' line: the port at each baud rate, the steady clock, sleeps.
doctor_probes::ProbeLine probe_line_on(const transport::PortSpec& spec, const GlobalOptions& g) {
  static const SteadyClock clock;
  doctor_probes::ProbeLine line;
  line.open = [spec, &g](uint32_t baud, bool discard_echo) {
    return twin::open_port(spec, port_options(g, baud, discard_echo));
  };
  line.clock = &clock;
  line.wait = [](Duration d) { std::this_thread::sleep_for(d); };
  line.interrupted = [] { return g_interrupted.load(); };
  return line;
}

doctor_probes::ProbeSettings probe_settings(const GlobalOptions& g) {
  doctor_probes::ProbeSettings s;
  s.baud = g.baud;
  s.reply_margin = g.reply_margin;
  s.silent_interval_k = g.silent_interval_k;
  s.delay_td = g.delay_td;
  s.alarm_polarity =
      lec::parse_alarm_polarity(g.alarm_polarity).value_or(lec::AlarmPolarity::ActiveHigh);
  return s;
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
  if (!bp.answering.empty()) {
    doctor_probes::read_controllers(
        *port, probe_settings(g), bp.answering, fix, [] { return g_interrupted.load(); }, obs);
  }
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

  dx::Observations obs = doctor_probes::asked(text, a.ids, g.echo, a.fix, probe_settings(g));

  if (spec.kind == transport::PortKind::Tcp) {
    through_gateway(spec, g, id_list, fix, obs);
  } else {
    doctor_probes::probe_line(
        probe_line_on(spec, g), probe_settings(g), id_list, fix, g.echo, obs, [&] {
          if (spec.kind != transport::PortKind::Serial) return;
          // LEC6_SYSFS_ROOT: a stand-in sysfs tree (the tests' USB adapter).
          const char* root = std::getenv("LEC6_SYSFS_ROOT");
          auto t = doctor_line::read_latency_timer(spec.device, root && *root ? root : "/sys");
          if (!t) return;
          obs.latency_timer_ms = t->ms;
          obs.latency_timer_path = t->file.string();
          if (a.fix && t->ms > 1) obs.latency_fixed = doctor_line::set_latency_timer_1ms(*t);
        });
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
