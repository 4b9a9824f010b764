// `lec sim`: the digital twin on a pseudo-terminal and/or TCP, for any master.

#include <signal.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "cli/app.hpp"
#include "lec6/modbus/timing.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/twin/sim_server.hpp"
#include "lec6/twin/state_file_io.hpp"

namespace lec6::cli {

namespace {

struct SimArgs {
  std::string pty;
  std::string tcp;
  std::string ids = "1";
  uint32_t baud = modbus::kDefaultBaud;
  std::string timing = "real";
  unsigned silent_interval_k = modbus::LineTiming{}.silent_interval_k;
  double delay_ms = to_ms(modbus::LineTiming{}.delay_td);
  std::string state;
  std::string stroke;
  double max_speed = sim::ActuatorConfig{}.max_speed_mm_s;
  double workpiece = 0.0;
  double initial_position = sim::ActuatorConfig{}.initial_position_mm;
  std::string name = sim::ActuatorConfig{}.equipment_name;
  bool trace = false;
  uint64_t seed = sim::FaultConfig{}.seed;
  double drop_rate = 0.0;
  double corrupt_rate = 0.0;
  double garbage_rate = 0.0;
  double delay_rate = 0.0;
  double extra_delay_ms = to_ms(sim::FaultConfig{}.extra_delay);
  bool workpiece_given = false;
  bool delay_rate_given = false;
  bool extra_delay_given = false;
};

std::string trim(std::string s) {
  const auto b = s.find_first_not_of(" \t");
  const auto e = s.find_last_not_of(" \t");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

unsigned parse_id(const std::string& text) {
  std::size_t used = 0;
  unsigned long v = 0;
  try {
    v = std::stoul(text, &used, 10);
  } catch (const std::exception&) {
    used = 0;
  }
  if (text.empty() || used != text.size() || v < 1 || v > 255) {
    throw UsageError(fmt::format(
        "--ids: '{}' is not a controller ID (1-255; 0 is the broadcast address)", text));
  }
  return static_cast<unsigned>(v);
}

// "1", "1,2,3", "1-16", "1-4,9": sorted, without duplicates.
std::vector<uint8_t> parse_ids(const std::string& text) {
  std::set<unsigned> ids;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t comma = text.find(',', pos);
    const std::string item =
        trim(text.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos));
    if (item.empty()) throw UsageError(fmt::format("--ids: empty item in '{}'", text));
    if (const auto dash = item.find('-'); dash != std::string::npos) {
      const unsigned lo = parse_id(trim(item.substr(0, dash)));
      const unsigned hi = parse_id(trim(item.substr(dash + 1)));
      if (lo > hi) throw UsageError(fmt::format("--ids: range '{}' runs backwards", item));
      for (unsigned i = lo; i <= hi; ++i) ids.insert(i);
    } else {
      ids.insert(parse_id(item));
    }
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  return {ids.begin(), ids.end()};
}

// 1-16 / 1, 3, 5-7: for the ready line.
std::string format_ids(const std::vector<uint8_t>& ids) {
  std::string out;
  for (std::size_t i = 0; i < ids.size();) {
    std::size_t j = i;
    while (j + 1 < ids.size() && ids[j + 1] == ids[j] + 1) ++j;
    if (!out.empty()) out += ", ";
    out += j > i ? fmt::format("{}-{}", ids[i], ids[j]) : fmt::format("{}", ids[i]);
    i = j + 1;
  }
  return out;
}

double parse_mm(const std::string& option, const std::string& text) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (text.empty() || used != text.size() || !std::isfinite(v)) {
    throw UsageError(fmt::format("{}: '{}' is not a number of mm", option, text));
  }
  return v;
}

std::pair<std::string, uint16_t> parse_tcp(const std::string& text) {
  const auto colon = text.rfind(':');
  std::string host = colon == std::string::npos ? std::string() : text.substr(0, colon);
  const std::string port_text = colon == std::string::npos ? text : text.substr(colon + 1);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']')
    host = host.substr(1, host.size() - 2);
  if (host.empty()) host = "127.0.0.1";
  std::size_t used = 0;
  unsigned long port = 0;
  try {
    port = std::stoul(port_text, &used, 10);
  } catch (const std::exception&) {
    used = 0;
  }
  if (port_text.empty() || used != port_text.size() || port > 65535) {
    throw UsageError(fmt::format(
        "--tcp: '{}' is not HOST:PORT (port 0-65535, 0 picks a free one; e.g. 127.0.0.1:5020)",
        text));
  }
  return {host, static_cast<uint16_t>(port)};
}

// Signals end the loop: the handler only writes to the server's eventfd.
std::atomic<twin::SimServer*> g_server{nullptr};

void on_stop_signal(int) {
  g_interrupted = true;
  if (auto* s = g_server.load()) s->stop();
}

void install_stop_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  struct sigaction ign {};
  ign.sa_handler = SIG_IGN;
  sigemptyset(&ign.sa_mask);
  sigaction(SIGPIPE, &ign, nullptr);  // a closed stdout/stderr must not kill the twin
}

void print_line(FILE* f, const std::string& line) {
  std::fputs(line.c_str(), f);
  std::fputc('\n', f);
  std::fflush(f);
}

// The parent's --baud / --silent-interval / --delay-ms / --trace, when given
// before `sim` (e.g. `lec --baud 9600 sim ...`) and not after it.
template <typename T>
void inherit(const CLI::App& parent, const CLI::App& sim, const std::string& name, T& value) {
  const CLI::Option* mine = sim.get_option_no_throw(name);
  const CLI::Option* theirs = parent.get_option_no_throw(name);
  if (mine && theirs && mine->count() == 0 && theirs->count() > 0) value = theirs->as<T>();
}

void run_sim(const SimArgs& a) {
  if (a.pty.empty() && a.tcp.empty()) {
    throw UsageError("sim: give --pty PATH, --tcp HOST:PORT, or both");
  }
  const std::vector<uint8_t> ids = parse_ids(a.ids);

  sim::ActuatorConfig config;
  if (!a.stroke.empty()) {
    const auto colon = a.stroke.find(':');
    if (colon == std::string::npos) {
      throw UsageError(fmt::format("--stroke: '{}' is not MIN:MAX in mm (e.g. 0:400)", a.stroke));
    }
    config.stroke_min_mm = parse_mm("--stroke", trim(a.stroke.substr(0, colon)));
    config.stroke_max_mm = parse_mm("--stroke", trim(a.stroke.substr(colon + 1)));
    if (!(config.stroke_min_mm <= 0.0 && 0.0 <= config.stroke_max_mm &&
          config.stroke_min_mm < config.stroke_max_mm)) {
      throw UsageError(fmt::format(
          "--stroke: '{}' must have MIN <= 0 <= MAX and MIN < MAX (mm, in the homed coordinate: "
          "the origin 0 lies on the stroke)",
          a.stroke));
    }
  }
  config.max_speed_mm_s = a.max_speed;
  config.initial_position_mm = a.initial_position;
  if (!(config.initial_position_mm >= config.stroke_min_mm &&
        config.initial_position_mm <= config.stroke_max_mm)) {
    throw UsageError(fmt::format("--initial-position: {} mm is outside the stroke {}:{} mm",
                                 config.initial_position_mm, config.stroke_min_mm,
                                 config.stroke_max_mm));
  }
  if (a.workpiece_given) config.workpiece_mm = a.workpiece;
  if (auto n = lec::EquipmentName::make(a.name); !n) {
    throw UsageError(fmt::format("--name: {}", n.error()));
  }
  config.equipment_name = a.name;
  if (auto problems = sim::validate(config); !problems.empty()) {
    std::string all;
    for (const auto& p : problems) all += (all.empty() ? "" : "; ") + p;
    throw UsageError("sim: " + all);
  }

  sim::LineConfig line;
  line.line.baud = a.baud;
  line.line.silent_interval_k = a.silent_interval_k;
  line.line.delay_td = to_duration(FractionalMilliseconds(a.delay_ms));
  line.timing = a.timing == "fast" ? sim::Timing::Fast : sim::Timing::Real;

  sim::FaultConfig faults;
  faults.seed = a.seed;
  faults.drop = a.drop_rate;
  faults.corrupt = a.corrupt_rate;
  faults.garbage = a.garbage_rate;
  faults.delay = a.delay_rate_given ? a.delay_rate : (a.extra_delay_given ? 1.0 : 0.0);
  faults.extra_delay = to_duration(FractionalMilliseconds(a.extra_delay_ms));

  std::optional<sim::EepromSet> saved;
  if (!a.state.empty()) {
    auto loaded = twin::load_state_file(a.state);
    if (!loaded) throw CommandFailed(kFailure, fmt::format("--state: {}", loaded.error()));
    saved = std::move(*loaded);
  }

  SteadyClock clock;
  sim::Bus bus(line, faults);
  const TimePoint power_on = clock.now();
  for (uint8_t id : ids) {
    std::optional<sim::Eeprom> eeprom;
    if (saved) {
      if (auto it = saved->find(id); it != saved->end()) eeprom = it->second;
    }
    bus.add(id, config, power_on, eeprom);
  }

  twin::SimServerOptions so;
  so.pty = !a.pty.empty();
  so.pty_link = a.pty;
  if (!a.tcp.empty()) so.tcp = parse_tcp(a.tcp);
  so.state_file = a.state;
  if (saved) {
    for (const auto& [id, eeprom] : *saved) {
      if (!std::binary_search(ids.begin(), ids.end(), id)) so.state_carry.emplace(id, eeprom);
    }
  }
  if (a.trace) so.trace = [](const std::string& l) { print_line(stderr, "lec sim: " + l); };
  so.warn = [](const std::string& l) { print_line(stderr, "lec sim: warning: " + l); };

  install_stop_handlers();
  twin::SimServer server(bus, std::move(so));
  g_server = &server;
  if (g_interrupted) server.stop();  // a signal before the handler knew the server
  struct Unregister {
    ~Unregister() { g_server = nullptr; }
  } unregister;

  print_line(stdout, fmt::format("lec sim: ready on {} (ids {}, timing {}, {} baud)",
                                 server.endpoints(), format_ids(ids), a.timing, a.baud));
  server.run();
}

}  // namespace

void add_sim_command(CLI::App& app) {
  auto a = std::make_shared<SimArgs>();
  auto* sim = app.add_subcommand(
      "sim",
      "Run the digital twin (controllers on one RS485 line) on a pseudo-terminal and/or TCP");
  sim->footer(
      "Masters open the --pty path as a serial port (any baud setting works: the twin times "
      "the line at --baud), or connect to --tcp and send RTU frames.\n"
      "Real timing: a reply is complete at end of query + Ts + 4 ms + Td + reply wire time "
      "(digest §1); fast timing: at once.\n"
      "Prints 'lec sim: ready on ...' once it answers; SIGINT/SIGTERM end it (state saved, link "
      "removed).");
  sim->add_option("--pty", a->pty,
                  "Create a pseudo-terminal with a symlink at PATH for masters to open")
      ->type_name("PATH");
  sim->add_option("--tcp", a->tcp,
                  "Serve RTU frames over TCP on HOST:PORT (HOST defaults to 127.0.0.1)")
      ->type_name("HOST:PORT");
  sim->add_option("--ids", a->ids, "Controller IDs on the line, e.g. 1,2,3 or 1-16 (1-255)")
      ->type_name("LIST")
      ->capture_default_str();
  sim->add_option("--baud", a->baud, "Line speed the twin times replies at")
      ->capture_default_str()
      ->check(CLI::IsMember({9600, 19200, 38400, 57600, 115200, 230400}));
  sim->add_option("--timing", a->timing,
                  "real: the controller's response time (digest §1); fast: no artificial delay")
      ->capture_default_str()
      ->check(CLI::IsMember({"real", "fast"}));
  sim->add_option("--silent-interval", a->silent_interval_k,
                  "Silent interval setting k (Ts = k x 3.5 characters)")
      ->capture_default_str()
      ->check(CLI::Range(1u, 100u));
  sim->add_option("--delay-ms", a->delay_ms, "Minimum communication delay Td, ms")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1000.0));
  sim->add_option("--state", a->state,
                  "Keep the EEPROM (steps, alarm history, name) in FILE: loaded at start, saved "
                  "atomically as it changes (at most every 200 ms) and at exit")
      ->type_name("FILE");
  sim->add_option("--stroke", a->stroke, "Stroke MIN:MAX in mm (MIN <= 0 <= MAX)")
      ->type_name("MIN:MAX")
      ->default_str(fmt::format("{}:{}", sim::ActuatorConfig{}.stroke_min_mm,
                                sim::ActuatorConfig{}.stroke_max_mm));
  sim->add_option("--max-speed", a->max_speed, "Maximum speed, mm/s (faster steps are clamped)")
      ->type_name("MM/S")
      ->capture_default_str()
      ->check(CLI::Validator(
          [](std::string& text) {
            double v = 0;
            try {
              v = std::stod(text);
            } catch (const std::exception&) {
              return std::string("not a number of mm/s: ") + text;
            }
            return v > 0 && std::isfinite(v) ? std::string() : "must be > 0 mm/s (is " + text + ")";
          },
          "> 0"));
  auto* workpiece = sim->add_option("--workpiece", a->workpiece,
                                    "A workpiece at this position, mm, for pushing (default: none)")
                        ->type_name("MM");
  sim->add_option("--initial-position", a->initial_position,
                  "Where the carriage stands at power-on, mm (within the stroke)")
      ->type_name("MM")
      ->capture_default_str();
  sim->add_option("--name", a->name, "Equipment name at D000E (up to 14 ASCII characters)")
      ->capture_default_str();
  sim->add_flag("--trace", a->trace, "Print every frame, decoded, with timestamps, on stderr");
  sim->add_option("--seed", a->seed, "Seed of the fault generator (runs are reproducible)")
      ->capture_default_str();
  sim->add_option("--drop-rate", a->drop_rate, "Probability a reply is not sent")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  sim->add_option("--corrupt-rate", a->corrupt_rate, "Probability one byte of a reply is changed")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  sim->add_option("--garbage-rate", a->garbage_rate,
                  "Probability of 1-4 random bytes right before a reply")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  auto* delay_rate = sim->add_option("--delay-rate", a->delay_rate,
                                     "Probability a reply starts --extra-delay-ms late "
                                     "(default: 1 if --extra-delay-ms is given, else 0)")
                         ->check(CLI::Range(0.0, 1.0));
  auto* extra_delay =
      sim->add_option("--extra-delay-ms", a->extra_delay_ms, "How late a delayed reply starts, ms")
          ->capture_default_str()
          ->check(CLI::Range(0.0, 60000.0));

  sim->callback([a, &app, sim, workpiece, delay_rate, extra_delay] {
    inherit(app, *sim, "--baud", a->baud);
    inherit(app, *sim, "--silent-interval", a->silent_interval_k);
    if (const CLI::Option* d = app.get_option_no_throw("--delay-ms");
        d && d->count() > 0 && sim->get_option("--delay-ms")->count() == 0) {
      a->delay_ms = d->as<double>();
    }
    if (const CLI::Option* t = app.get_option_no_throw("--trace"); t && t->count() > 0)
      a->trace = true;
    a->workpiece_given = workpiece->count() > 0;
    a->delay_rate_given = delay_rate->count() > 0;
    a->extra_delay_given = extra_delay->count() > 0;
    run_sim(*a);
  });
}

}  // namespace lec6::cli
