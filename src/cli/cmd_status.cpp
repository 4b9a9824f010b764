// status, watch, alarms, name: looking at a controller without changing it.

#include <chrono>
#include <ctime>
#include <fstream>
#include <thread>

#include <unistd.h>

#include "cli/app.hpp"
#include "cli/duration_option.hpp"
#include "cli/views.hpp"
#include "lec6/lec/alarm_check.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::cli {
namespace {

void run_status(Session& s) {
  auto& c = s.client();
  const auto state = c.read_state();
  const auto flags = c.read_flags();
  const auto controls = c.read_controls();
  // Never from X4F alone (issue 33): X4F against the alarm code and BUSY.
  const auto judged =
      lec::judge_alarm(flags, c.read_alarms().groups[0], c.options().alarm_polarity);
  const auto& alarms = judged.codes;
  if (s.json()) {
    auto j = state_json(state, flags, alarms);
    if (!judged.disagreement.empty()) j["alarm_check"] = judged.disagreement;
    j["serial_mode"] = controls.serial_mode;
    j["servo_on"] = controls.test(lec::Coil::SVON);
    j["id"] = s.options().id;
    print_json(j);
    return;
  }
  fmt::print("Controller ID {} on {}\n", s.options().id, s.port_description());
  fmt::print("  Position   {:>10} mm   target {} mm\n", lec::format_mm(state.position_001mm),
             lec::format_mm(state.target_001mm));
  fmt::print("  Speed      {:>10} mm/s\n", state.speed_mm_s);
  fmt::print("  Thrust     {:>10} %\n", state.thrust_pct);
  fmt::print("  Step       {:>10}   (OUT0-5 = {})\n", state.step_no, flags.out());
  fmt::print("  Flags      {}\n", flags.describe());
  fmt::print("  Input mode {}\n", controls.serial_mode
                                      ? "serial (Y30 = 1)"
                                      : "parallel (Y30 = 0): run `lec serial on` to operate");
  if (alarms.empty()) {
    fmt::print("  Alarms     none\n");
  } else {
    for (uint8_t a : alarms) fmt::print("  Alarm      {}: {}\n", a, lec::alarm_meaning(a));
  }
  if (!judged.disagreement.empty()) fmt::print("  Check      {}\n", judged.disagreement);
}

struct WatchOptions {
  std::string record;
  Duration duration{};  // 0: until Ctrl-C
  int count = 0;        // 0: no limit
  Duration interval{};
};

// The sample's wall-clock time, to match against a PLC's log (issue 27):
// ISO 8601, UTC, milliseconds: 2026-11-24T19:22:01.123Z.
std::string wall_clock_utc() {
  const auto now = std::chrono::system_clock::now();
  const auto secs = std::chrono::floor<std::chrono::seconds>(now);
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now - secs).count();
  const std::time_t tt = std::chrono::system_clock::to_time_t(secs);
  std::tm utc{};
  gmtime_r(&tt, &utc);
  return fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}.{:03}Z", utc.tm_year + 1900,
                     utc.tm_mon + 1, utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec, ms);
}

void run_watch(Session& s, const WatchOptions& o) {
  auto& c = s.client();
  std::ofstream csv;
  if (!o.record.empty()) {
    csv.open(o.record);
    if (!csv) throw CommandFailed(kFailure, fmt::format("cannot write {}", o.record));
    csv << "time_s,position_mm,speed_mm_s,thrust_pct,target_mm,step,busy,svre,seton,inp,area,warea,"
           "estop,alarm,out,wall_clock_utc\n";
  }
  const TimePoint start = c.clock().now();
  const bool tty = isatty(fileno(stdout));
  int samples = 0;
  while (!g_interrupted) {
    lec::StateData state;
    lec::StatusFlags flags;
    try {
      state = c.read_state();
      flags = c.read_flags();
    } catch (const client::Cancelled&) {  // Ctrl-C mid-read: end as between samples
      break;
    }
    const double t = to_seconds(c.clock().now() - start);
    ++samples;
    if (csv) {
      csv << fmt::format("{:.4f},{},{},{},{},{},{:d},{:d},{:d},{:d},{:d},{:d},{:d},{:d},{},{}\n", t,
                         lec::format_mm(state.position_001mm), state.speed_mm_s, state.thrust_pct,
                         lec::format_mm(state.target_001mm), state.step_no, flags.busy(),
                         flags.svre(), flags.seton(), flags.inp(), flags.area(), flags.warea(),
                         flags.estop(), flags.alarm(), flags.out(), wall_clock_utc());
    }
    if (s.json()) {
      auto j = state_json(state, flags, {});
      j["time_s"] = t;
      fmt::print("{}\n", dump_json(j));
    } else {
      fmt::print("{}{:8.3f} s {}{}", tty ? "\r" : "", t, progress_line(state, flags),
                 tty ? "\033[K" : "\n");
    }
    std::fflush(stdout);
    if ((o.count && samples >= o.count) ||
        (o.duration > Duration::zero() && t >= to_seconds(o.duration)))
      break;
    if (o.interval > Duration::zero()) {
      const TimePoint next = c.clock().now() + o.interval;
      while (c.clock().now() < next && !g_interrupted)
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  if (tty && !s.json()) fmt::print("\n");
  if (!s.json())
    fmt::print(stderr, "{} samples{}\n", samples,
               o.record.empty() ? "" : " recorded in " + o.record);
}

void run_alarms(Session& s) {
  auto& c = s.client();
  const auto flags = c.read_flags();
  const auto history = c.read_alarms();
  const auto active = flags.alarm() ? history.groups[0].present() : std::vector<uint8_t>{};
  if (s.json()) {
    nlohmann::json j;
    j["active"] = nlohmann::json::array();
    for (uint8_t a : active) j["active"].push_back(alarm_json(a));
    j["history"] = nlohmann::json::array();
    for (std::size_t g = 0; g < history.groups.size(); ++g) {
      nlohmann::json codes = nlohmann::json::array();
      for (uint8_t a : history.groups[g].present()) codes.push_back(alarm_json(a));
      j["history"].push_back({{"group", g}, {"alarms", codes}});
    }
    print_json(j);
    return;
  }
  if (active.empty()) {
    fmt::print("Active alarms: none\n");
  } else {
    fmt::print("Active alarms (clear with `lec reset`):\n");
    for (uint8_t a : active) fmt::print("  {:3}  {}\n", a, lec::alarm_meaning(a));
  }
  fmt::print("History (group 0 newest):\n");
  bool any = false;
  for (std::size_t g = 0; g < history.groups.size(); ++g) {
    for (uint8_t a : history.groups[g].present()) {
      fmt::print("  group {:2}: {:3}  {}\n", g, a, lec::alarm_meaning(a));
      any = true;
    }
  }
  if (!any) fmt::print("  (empty)\n");
}

void run_name(Session& s) {
  const auto name = s.client().read_name();
  if (s.json()) {
    print_json({{"equipment_name", name.text}, {"id", s.options().id}});
  } else {
    fmt::print("{}\n", name.text.empty() ? "(no equipment name set)" : name.text);
  }
}

}  // namespace

void add_status_commands(CLI::App& app, Session& session) {
  app.add_subcommand("status", "State, flags and active alarms")->callback([&] {
    run_status(session);
  });

  auto watch_opts = std::make_shared<WatchOptions>();
  auto* watch =
      app.add_subcommand("watch", "Live view of position, speed, thrust and flags until Ctrl-C");
  watch->add_option("--record", watch_opts->record,
                    "Log every sample to a CSV file: time_s from the start, and wall_clock_utc "
                    "(ISO 8601, ms) to match against a PLC's log");
  add_duration_option(watch, "--for", watch_opts->duration, "Stop after this long, e.g. 30s",
                      {std::chrono::milliseconds(1), std::chrono::hours(24 * 365)},
                      BareNumber::Seconds)
      ->default_str("");
  watch->add_option("--count", watch_opts->count, "Stop after this many samples")
      ->check(CLI::Range(1, 1000000000));
  add_duration_option(watch, "--interval", watch_opts->interval,
                      "Pause between samples, e.g. 100ms (default: as fast as the line)",
                      {Duration::zero(), std::chrono::seconds(60)}, BareNumber::Milliseconds);
  watch->callback([&session, watch_opts] { run_watch(session, *watch_opts); });

  app.add_subcommand("alarms", "Active alarms and the 16-group history, with meanings")
      ->callback([&] { run_alarms(session); });
  app.add_subcommand("name", "The controller's equipment name (D000E)")->callback([&] {
    run_name(session);
  });
}

}  // namespace lec6::cli
