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
#include "cli/duration_option.hpp"
#include "cli/profile_option.hpp"
#include "cli/sim_args.hpp"
#include "cli/sim_calibrate.hpp"
#include "lec6/modbus/timing.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/twin/field_profile.hpp"
#include "lec6/twin/sim_server.hpp"
#include "lec6/twin/state_file_io.hpp"

namespace lec6::cli {

namespace {

using sim_args::format_ids;
using sim_args::parse_ids;
using sim_args::parse_mm;
using sim_args::parse_tcp;
using sim_args::trim;
using std::chrono::seconds;

// Options renamed when durations got units: the old name still works (hidden).
constexpr std::pair<const char*, const char*> kRenamed[] = {
    {"--delay-ms", "--td"},
    {"--busy-delay-ms", "--busy-delay"},
    {"--busy-min-ms", "--busy-min"},
    {"--extra-delay-ms", "--extra-delay"},
};

struct SimArgs {
  std::string pty;
  std::string tcp;
  std::string ids = "1";
  std::string profile;
  std::string calibrate;  // --calibrate FILE: fit a profile to a capture, print it, exit
  uint32_t baud = modbus::kDefaultBaud;
  std::string timing = "real";
  unsigned silent_interval_k = modbus::LineTiming{}.silent_interval_k;
  Duration delay_td = modbus::LineTiming{}.delay_td;
  std::string state;
  std::string stroke;
  double max_speed = sim::ActuatorConfig{}.max_speed_mm_s;
  double workpiece = 0.0;
  double wear = 0.0;  // % per metre travelled (issue 26)
  double initial_position = sim::ActuatorConfig{}.initial_position_mm;
  std::string name = sim::ActuatorConfig{}.equipment_name;
  Duration busy_delay{};
  Duration busy_min{};
  bool target_update_late = false;
  double noise_rate = 0.0;
  bool trace = false;
  uint64_t seed = sim::FaultConfig{}.seed;
  double drop_rate = 0.0;
  double corrupt_rate = 0.0;
  double garbage_rate = 0.0;
  double delay_rate = 0.0;
  Duration extra_delay = sim::FaultConfig{}.extra_delay;
  Duration usb_latency{};
  std::string tap;
  Duration tap_latency{};
  bool echo_adapter = false;  // lec doctor's faults: see add_sim_command
  bool strict_baud = false;   // --strict-baud: the default since issue 33, still accepted
  bool any_baud = false;      // --any-baud: answer a pty master at any rate
  bool ideal = false;         // --ideal: the manual's ideal twin instead of the default
  std::string duplicate_ids;
  double other_master_hz = 0.0;
  std::set<std::string> given;  // options on the command line: they override the profile
  bool has(const std::string& option) const { return given.count(option) > 0; }
};

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

// The twin's settings: the profile's (or the defaults), then every option
// given on the command line.
twin::FieldProfile settings(const SimArgs& a) {
  twin::FieldProfile p = profile_option(a.profile, a.ideal);
  sim::ActuatorConfig& config = p.actuator;
  if (a.has("--stroke")) {
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
  if (a.has("--max-speed")) config.max_speed_mm_s = a.max_speed;
  if (a.has("--initial-position")) config.initial_position_mm = a.initial_position;
  if (!(config.initial_position_mm >= config.stroke_min_mm &&
        config.initial_position_mm <= config.stroke_max_mm)) {
    throw UsageError(fmt::format("--initial-position: {} mm is outside the stroke {}:{} mm",
                                 config.initial_position_mm, config.stroke_min_mm,
                                 config.stroke_max_mm));
  }
  if (a.has("--workpiece")) config.workpiece_mm = a.workpiece;
  if (a.has("--wear")) config.wear_pct_per_m = a.wear;
  if (a.has("--name")) {
    if (auto n = lec::EquipmentName::make(a.name); !n) {
      throw UsageError(fmt::format("--name: {}", n.error()));
    }
    config.equipment_name = a.name;
  }
  if (a.has("--busy-delay")) config.busy_delay = a.busy_delay;
  if (a.has("--busy-min")) config.busy_min = a.busy_min;
  if (a.has("--target-update-late")) config.target_update_late = a.target_update_late;
  if (auto problems = sim::validate(config); !problems.empty()) {
    std::string all;
    for (const auto& pr : problems) all += (all.empty() ? "" : "; ") + pr;
    throw UsageError("sim: " + all);
  }

  sim::LineConfig& line = p.line;
  if (a.has("--baud")) line.line.baud = a.baud;
  if (a.has("--silent-interval")) line.line.silent_interval_k = a.silent_interval_k;
  if (a.has("--td")) line.line.delay_td = a.delay_td;
  if (a.has("--timing")) line.timing = a.timing == "fast" ? sim::Timing::Fast : sim::Timing::Real;

  sim::FaultConfig& faults = p.faults;
  if (a.has("--seed")) faults.seed = a.seed;
  if (a.has("--drop-rate")) faults.drop = a.drop_rate;
  if (a.has("--corrupt-rate")) faults.corrupt = a.corrupt_rate;
  if (a.has("--garbage-rate")) faults.garbage = a.garbage_rate;
  if (a.has("--delay-rate")) faults.delay = a.delay_rate;
  if (a.has("--extra-delay")) {
    faults.extra_delay = a.extra_delay;
    if (!a.has("--delay-rate")) faults.delay = 1.0;  // a delay given alone applies to every reply
  }
  if (a.has("--noise-rate")) faults.noise_rate = a.noise_rate;
  if (a.has("--duplicate-ids")) faults.duplicate_ids = parse_ids(a.duplicate_ids);
  return p;
}

// The settings that differ from a factory controller on a quiet line, for the
// ready line: whoever reads a log sees which quirks the twin played.
std::string unusual_settings(const twin::FieldProfile& p) {
  std::string out;
  if (p.line.line.delay_td != modbus::LineTiming{}.delay_td)
    out += ", Td " + format_duration(p.line.line.delay_td);
  if (p.actuator.busy_delay > Duration::zero())
    out += ", busy-delay " + format_duration(p.actuator.busy_delay);
  if (p.actuator.busy_min > Duration::zero())
    out += ", busy-min " + format_duration(p.actuator.busy_min);
  if (p.actuator.target_update_late) out += ", target-update-late";
  // The assumptions of issue 33 (docs/twin-fidelity.md, section A) that differ from the ideal.
  const sim::ActuatorConfig ideal = sim::ideal_config();
  if (p.actuator.origin_speed_mm_s != ideal.origin_speed_mm_s)
    out += fmt::format(", homing {:g} mm/s", p.actuator.origin_speed_mm_s);
  if (p.actuator.homing_direction != ideal.homing_direction) out += ", homing to the max end";
  if (p.actuator.seton_on_rehome != ideal.seton_on_rehome) out += ", SETON cleared on re-home";
  if (!p.actuator.reset_cancels_homing) out += ", RESET does not cancel homing";
  if (p.actuator.retarget != ideal.retarget) out += ", retarget stops first";
  if (p.actuator.alarm_polarity != ideal.alarm_polarity) out += ", ALARM active-low";
  if (p.actuator.setup_left_high != ideal.setup_left_high)
    out += ", SETUP left high refuses starts";
  if (p.actuator.wear_pct_per_m > 0)
    out += fmt::format(", wear {:g} %/m", p.actuator.wear_pct_per_m);
  if (p.faults.noise_rate > 0) out += fmt::format(", noise {}/s", p.faults.noise_rate);
  if (!p.faults.duplicate_ids.empty())
    out += ", duplicate ids " + format_ids(p.faults.duplicate_ids);
  return out;
}

// --usb-latency / --tap-latency, for the ready line.
std::string adapter_settings(const SimArgs& a) {
  std::string out;
  if (a.usb_latency > Duration::zero()) out += ", usb-latency " + format_duration(a.usb_latency);
  if (!a.tap.empty()) out += ", tap " + a.tap + " listen-only";
  if (!a.tap.empty() && a.tap_latency > Duration::zero())
    out += ", tap-latency " + format_duration(a.tap_latency);
  if (a.echo_adapter) out += ", echo adapter";
  if (a.any_baud) out += ", any baud";
  if (a.other_master_hz > 0) out += fmt::format(", other master {}/s", a.other_master_hz);
  return out;
}

void run_sim(const SimArgs& a) {
  if (a.pty.empty() && a.tcp.empty()) {
    throw UsageError("sim: give --pty PATH, --tcp HOST:PORT, or both");
  }
  const std::vector<uint8_t> ids = parse_ids(a.ids);
  const twin::FieldProfile p = settings(a);
  const sim::ActuatorConfig& config = p.actuator;
  const sim::LineConfig& line = p.line;
  const sim::FaultConfig& faults = p.faults;

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
  so.usb_latency = a.usb_latency;
  so.tap_link = a.tap;
  so.tap_latency = a.tap_latency;
  if (a.tap_latency > Duration::zero() && a.tap.empty())
    throw UsageError("sim: --tap-latency needs --tap PATH");
  if (saved) {
    for (const auto& [id, eeprom] : *saved) {
      if (!std::binary_search(ids.begin(), ids.end(), id)) so.state_carry.emplace(id, eeprom);
    }
  }
  if (a.trace) so.trace = [](const std::string& l) { print_line(stderr, "lec sim: " + l); };
  so.warn = [](const std::string& l) { print_line(stderr, "lec sim: warning: " + l); };
  so.echo_adapter = a.echo_adapter;
  so.strict_baud = !a.any_baud;  // issue 33: a real line answers only its own baud
  if (a.other_master_hz > 0) {
    so.other_master_period = Duration(static_cast<int64_t>(1e9 / a.other_master_hz));
    so.other_master_id = ids.front();
  }

  install_stop_handlers();
  twin::SimServer server(bus, std::move(so));
  g_server = &server;
  if (g_interrupted) server.stop();  // a signal before the handler knew the server
  struct Unregister {
    ~Unregister() { g_server = nullptr; }
  } unregister;

  print_line(stdout, fmt::format("lec sim: ready on {} (ids {}, timing {}, {} baud{}{}{})",
                                 server.endpoints(), format_ids(ids),
                                 line.timing == sim::Timing::Fast ? "fast" : "real", line.line.baud,
                                 p.name.empty() ? "" : ", profile " + p.name, unusual_settings(p),
                                 adapter_settings(a)));
  server.run();
}

}  // namespace

void add_sim_command(CLI::App& app, const GlobalOptions& globals) {
  auto a = std::make_shared<SimArgs>();
  auto* sim = app.add_subcommand(
      "sim",
      "Run the digital twin (controllers on one RS485 line) on a pseudo-terminal and/or TCP");
  sim->footer(
      "Masters open the --pty path as a serial port set to --baud (a master at another rate is "
      "heard as garbage and hears garbage, as on a real line; --any-baud answers any rate), or "
      "connect to --tcp and send RTU frames.\n"
      "The default twin follows the field's evidence (BUSY 20 ms late, shortest BUSY pulse "
      "60 ms, homing at 50 mm/s, SETON cleared during a re-home: docs/twin-fidelity.md); "
      "--ideal is the manual's ideal controller.\n"
      "Real timing: a reply is complete at end of query + Ts + 4 ms + Td + reply wire time "
      "(digest §1); fast timing: at once.\n"
      "Prints 'lec sim: ready on ...' once it answers; SIGINT/SIGTERM end it (state saved, link "
      "removed).\n"
      "Field quirks (--busy-delay, --busy-min, --target-update-late, --noise-rate) make the "
      "twin as unkind as a real controller; profiles/field-quirks.yaml combines them all "
      "(--profile FILE; options given here override the profile). Profile keys:\n" +
      twin::field_profile_keys());
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
  add_duration_option(sim, "--td", a->delay_td, "Minimum communication delay Td",
                      {Duration::zero(), seconds(1)});
  add_renamed_duration_option(sim, "--delay-ms", "--td", a->delay_td, BareNumber::Milliseconds,
                              {Duration::zero(), seconds(1)});
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
  sim->add_option("--profile", a->profile,
                  "Load the twin's settings from a YAML/JSON field profile (e.g. "
                  "profiles/field-quirks.yaml); options given override it")
      ->type_name("FILE");
  sim->add_option("--calibrate", a->calibrate,
                  "Fit the twin to a capture of a real controller (lec --record, lec sniff) and "
                  "print the profile (YAML, for --profile) on stdout; residuals and what the "
                  "capture could not determine go to stderr. Nothing else runs")
      ->type_name("FILE");
  sim->add_option("--workpiece", a->workpiece,
                  "A workpiece at this position, mm, for pushing (default: none)")
      ->type_name("MM");
  sim->add_option("--wear", a->wear,
                  "Wear: every metre travelled adds this many % to thrust and takes it off speed, "
                  "so repeated moves grow longer (drift warnings of lec serve, docs/history.md)")
      ->type_name("PCT_PER_M")
      ->check(CLI::Range(0.0, 1000.0));
  sim->add_option("--initial-position", a->initial_position,
                  "Where the carriage stands at power-on, mm (within the stroke)")
      ->type_name("MM")
      ->capture_default_str();
  sim->add_option("--name", a->name, "Equipment name at D000E (up to 14 ASCII characters)")
      ->capture_default_str();
  const DurationLimits quirk{Duration::zero(), seconds(10)};
  add_duration_option(
      sim, "--busy-delay", a->busy_delay,
      "Field quirk: BUSY rises this long after the controller took a start "
      "(DRIVE, D9100, SETUP); until then BUSY, INP and OUT0-5 keep their old values",
      quirk);
  add_renamed_duration_option(sim, "--busy-delay-ms", "--busy-delay", a->busy_delay,
                              BareNumber::Milliseconds, quirk);
  add_duration_option(sim, "--busy-min", a->busy_min,
                      "Field quirk: the shortest BUSY pulse, for a move already at its target",
                      quirk);
  add_renamed_duration_option(sim, "--busy-min-ms", "--busy-min", a->busy_min,
                              BareNumber::Milliseconds, quirk);
  sim->add_flag("--target-update-late,!--no-target-update-late", a->target_update_late,
                "Field quirk: D9004 target and D9006 step change only when BUSY rises");
  sim->add_option("--noise-rate", a->noise_rate,
                  "Field quirk: random bytes per second on the idle line (heard by every master "
                  "and controller)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e9));
  sim->add_flag("--echo-adapter", a->echo_adapter,
                "Line fault (pty): a 2-wire adapter that echoes every byte the master sends");
  sim->add_flag("--strict-baud", a->strict_baud,
                "(The default) answer only a pty master whose port is set to --baud")
      ->group("");
  sim->add_flag("--any-baud", a->any_baud,
                "Answer a pty master whatever rate its port is set to (for tools that cannot set "
                "a baud). A pty carries no bit timing: the rate is read from the port's settings "
                "(termios), which the master side shares");
  sim->add_flag("--ideal", a->ideal,
                "The manual's ideal controller (no BUSY delay, homing at 20 mm/s, SETON kept on "
                "re-home) instead of the default twin, which follows the field's evidence "
                "(docs/twin-fidelity.md); a --profile is read over it");
  sim->add_option("--duplicate-ids", a->duplicate_ids,
                  "Line fault: these IDs are each set on two controllers; both answer and half "
                  "of the replies collide (garbled, the ID intact)")
      ->type_name("LIST");
  sim->add_option("--other-master", a->other_master_hz,
                  "Line fault (pty): a second master reads D9000 of the first ID this many times "
                  "a second; every master hears its queries and the replies")
      ->type_name("HZ")
      ->check(CLI::Range(0.0, 1000.0));
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
  sim->add_option("--delay-rate", a->delay_rate,
                  "Probability a reply starts --extra-delay late "
                  "(default: 1 if --extra-delay is given, else 0)")
      ->check(CLI::Range(0.0, 1.0));
  add_duration_option(sim, "--extra-delay", a->extra_delay, "How late a delayed reply starts",
                      {Duration::zero(), seconds(60)});
  add_renamed_duration_option(sim, "--extra-delay-ms", "--extra-delay", a->extra_delay,
                              BareNumber::Milliseconds, {Duration::zero(), seconds(60)});
  add_duration_option(sim, "--usb-latency", a->usb_latency,
                      "Fault: the --pty hands replies to the master the way a USB adapter's "
                      "latency timer does, in lumps every DURATION (FTDI's default: 16ms; "
                      "0: each reply whole, at once)",
                      {Duration::zero(), seconds(1)});
  sim->add_option("--tap", a->tap,
                  "Also create a listen-only pseudo-terminal at PATH carrying every byte on the "
                  "line (every master, every controller, the noise) with its timing: for "
                  "lec sniff --port PATH")
      ->type_name("PATH");
  add_duration_option(sim, "--tap-latency", a->tap_latency,
                      "Deliver the --tap's bytes in lumps every DURATION, as a USB adapter's "
                      "latency timer does (e.g. 16ms; 0: each frame as it ends)",
                      {Duration::zero(), seconds(1)});

  sim->callback([a, &app, &globals, sim] {
    inherit(app, *sim, "--baud", a->baud);
    inherit(app, *sim, "--silent-interval", a->silent_interval_k);
    for (const CLI::Option* o : sim->get_options()) {
      // By its long name: CLI11's get_name() is empty for a hidden (renamed) option.
      if (o->count() > 0 && !o->get_lnames().empty()) a->given.insert("--" + o->get_lnames()[0]);
    }
    // Old spellings (hidden, deprecated) set the same values as the new ones.
    for (const auto& [old_name, new_name] : kRenamed) {
      if (a->given.count(old_name)) a->given.insert(new_name);
    }
    const bool td_on_parent =
        app.get_option("--td")->count() > 0 || app.get_option("--delay-ms")->count() > 0;
    if (td_on_parent && !a->has("--td")) {
      a->delay_td = globals.delay_td;
      a->given.insert("--td");
    }
    if (const CLI::Option* t = app.get_option_no_throw("--trace"); t && t->count() > 0)
      a->trace = true;
    for (const char* parent : {"--baud", "--silent-interval"}) {
      if (const CLI::Option* o = app.get_option_no_throw(parent); o && o->count() > 0)
        a->given.insert(parent);
    }
    if (a->given.count("--no-target-update-late")) a->given.insert("--target-update-late");
    if (!a->calibrate.empty()) {
      run_calibrate(a->calibrate);
      return;
    }
    run_sim(*a);
  });
}

}  // namespace lec6::cli
