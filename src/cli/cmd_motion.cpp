// serial, servo, home, move, jog, hold, stop, reset: commands that change
// what the actuator does. Every value is checked against the manual's ranges
// before anything is sent.

#include <poll.h>
#include <unistd.h>

#include "cli/app.hpp"
#include "cli/duration_option.hpp"
#include "cli/move_report.hpp"
#include "cli/views.hpp"
#include "lec6/lec/alarm_check.hpp"
#include "lec6/lec/step_data.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::cli {
namespace {

using lec::StepField;

bool parse_on_off(const std::string& v, std::string_view what) {
  if (v == "on" || v == "1") return true;
  if (v == "off" || v == "0") return false;
  throw UsageError(fmt::format("{}: expected on or off, got '{}'", what, v));
}

// A progress printer: a refreshing line on a terminal, nothing otherwise.
std::function<void(const client::Progress&)> progress_printer(const Session& s) {
  if (s.json() || !isatty(fileno(stderr))) return {};
  return [](const client::Progress& p) {
    fmt::print(stderr, "\r{:6.2f} s {}\033[K", to_seconds(p.elapsed),
               progress_line(p.state, p.flags));
  };
}

void end_progress(const Session& s) {
  if (!s.json() && isatty(fileno(stderr))) fmt::print(stderr, "\r\033[K");
}

int64_t field_value(StepField f, const std::string& text) {
  auto v = lec::parse_field(f, text);
  if (!v) throw UsageError(v.error());
  return *v;
}

struct MoveArgs {
  int step = -1;
  std::string to, speed, accel, decel, moving_force, in_position, area, push, trigger, push_speed;
  bool relative = false;
  bool keep = false;
  bool no_wait = false;
  Duration timeout = std::chrono::seconds(60);
};

client::DirectMove direct_move(const MoveArgs& a) {
  client::DirectMove m;
  m.relative = a.relative;
  m.keep = a.keep;
  m.position_001mm = static_cast<int32_t>(field_value(StepField::Position, a.to));
  auto u16 = [](StepField f, const std::string& t) -> std::optional<uint16_t> {
    if (t.empty()) return std::nullopt;
    return static_cast<uint16_t>(field_value(f, t));
  };
  auto i32 = [](StepField f, const std::string& t) -> std::optional<int32_t> {
    if (t.empty()) return std::nullopt;
    return static_cast<int32_t>(field_value(f, t));
  };
  m.speed_mm_s = u16(StepField::Speed, a.speed);
  m.acceleration_mm_s2 = u16(StepField::Acceleration, a.accel);
  m.deceleration_mm_s2 = u16(StepField::Deceleration, a.decel);
  m.moving_force_pct = u16(StepField::MovingForce, a.moving_force);
  m.in_position_001mm = i32(StepField::InPosition, a.in_position);
  m.pushing_force_pct = u16(StepField::PushingForce, a.push);
  m.trigger_level_pct = u16(StepField::TriggerLevel, a.trigger);
  m.pushing_speed_mm_s = u16(StepField::PushingSpeed, a.push_speed);
  if (!a.area.empty()) {
    const auto colon = a.area.find(':');
    if (colon == std::string::npos)
      throw UsageError(fmt::format("--area '{}': expected A:B in mm, e.g. 100:200", a.area));
    m.area1_001mm = static_cast<int32_t>(field_value(StepField::Area1, a.area.substr(0, colon)));
    m.area2_001mm = static_cast<int32_t>(field_value(StepField::Area2, a.area.substr(colon + 1)));
  }
  if (!m.pushing_force_pct && (m.trigger_level_pct || m.pushing_speed_mm_s)) {
    throw UsageError("--trigger and --push-speed belong to a pushing move: give --push PCT too");
  }
  return m;
}

void run_move(Session& s, const MoveArgs& a) {
  const bool by_step = a.step >= 0;
  if (by_step == !a.to.empty()) throw UsageError("move: give exactly one of --step N or --to MM");
  if (by_step && (a.relative || a.keep || !a.speed.empty() || !a.push.empty() || !a.area.empty())) {
    throw UsageError("move --step runs the stored step as it is: edit it with `lec step set`");
  }
  const client::DirectMove m =
      by_step ? client::DirectMove{} : direct_move(a);  // validate before opening
  auto& axis = s.axis();
  const auto deadline = s.deadline_in(a.timeout);
  auto wait = s.wait_options(progress_printer(s));
  if (a.no_wait) {
    axis.start(m);
    const auto flags = s.client().read_flags();
    const auto state = s.client().read_state();
    if (s.json()) {
      print_json(state_json(state, flags, {}));
    } else {
      fmt::print("Started: target {} mm ({})\n", lec::format_mm(state.target_001mm),
                 flags.describe());
    }
    return;
  }
  with_move_report(s, [&] {
    report_move(s, by_step ? axis.run_step(static_cast<unsigned>(a.step), deadline, wait)
                           : axis.move(m, deadline, wait));
  });
}

bool stdin_has_input() {
  pollfd p{STDIN_FILENO, POLLIN, 0};
  return ::poll(&p, 1, 0) > 0 && (p.revents & (POLLIN | POLLHUP));
}

void run_jog(Session& s, const std::string& dir, Duration jog_for) {
  if (dir != "+" && dir != "-")
    throw UsageError(fmt::format("jog: direction must be + or -, got '{}'", dir));
  auto& axis = s.axis();
  const bool held = jog_for <= Duration::zero();
  if (held && !s.json())
    fmt::print(stderr, "Jogging {}: press Enter to stop (Ctrl-C stops too, exit 130)\n", dir);
  auto wait = s.wait_options(progress_printer(s));
  if (held && isatty(STDIN_FILENO)) {
    wait.cancel = [] { return g_interrupted.load() || stdin_has_input(); };
  }
  const TimePoint until = held ? TimePoint::max() : s.deadline_in(jog_for);
  const auto r = axis.jog(dir == "+", until, s.deadline_in(std::chrono::hours(24)), wait);
  end_progress(s);
  if (s.json()) {
    print_json(state_json(r.state, r.flags, {}));
  } else {
    fmt::print("Jog stopped at {} mm\n", lec::format_mm(r.state.position_001mm));
  }
}

void say(const Session& s, const std::string& text, nlohmann::json j = {});

// A stop or hold judged by the axis (client/stop.hpp): exit 0 only when a
// read shows it at rest; otherwise the report says what was sent and what
// the axis does, and the exit code is kFailure.
void report_stop(Session& session, client::StopKind kind) {
  const auto r = session.axis().stop(kind, client::StopPolicy{});
  if (!r.stopped) throw CommandFailed(kFailure, r.describe());
  say(session, r.describe(),
      {{"stopped", true},
       {"position_mm", static_cast<double>(r.state.position_001mm) / 100.0},
       {"actions", r.actions},
       {"took_s", to_seconds(r.took)}});
}

void say(const Session& s, const std::string& text, nlohmann::json j) {
  if (s.json()) {
    j["ok"] = true;
    print_json(j);
  } else {
    fmt::print("{}\n", text);
  }
}

}  // namespace

void add_motion_commands(CLI::App& app, Session& session) {
  auto value = std::make_shared<std::string>();
  auto servo_timeout = std::make_shared<Duration>(std::chrono::seconds(10));

  auto* serial = app.add_subcommand("serial", "Serial (on) or parallel (off) input mode: Y30");
  serial->add_option("state", *value, "on|off")->required();
  serial->callback([&session, value] {
    const bool on = parse_on_off(*value, "serial");
    session.allow_broadcast();  // a write only: `lec --id 0 serial on` reaches every controller
    session.axis().set_serial_mode(on);
    say(session, on ? "Serial input mode (Y30 = 1)" : "Parallel input mode (Y30 = 0)",
        {{"serial_mode", on}});
  });

  auto* servo = app.add_subcommand("servo", "Servo on/off (Y19 SVON), waiting for SVRE");
  servo->add_option("state", *value, "on|off")->required();
  add_deadline_option(servo, *servo_timeout, "How long to wait for SVRE");
  servo->callback([&session, value, servo_timeout] {
    const bool on = parse_on_off(*value, "servo");
    auto& axis = session.axis();
    const auto deadline = session.deadline_in(*servo_timeout);
    if (on) {
      axis.servo_on(deadline, session.wait_options());
    } else {
      axis.servo_off(deadline, session.wait_options());
    }
    say(session, on ? "Servo on (SVRE = 1)" : "Servo off (SVRE = 0)", {{"svre", on}});
  });

  auto home_timeout = std::make_shared<Duration>(std::chrono::seconds(60));
  auto* home = app.add_subcommand(
      "home", "Return to origin: SETUP, wait for the move to end (SETON, at 0), SETUP off");
  add_deadline_option(home, *home_timeout, "Deadline for the return to origin");
  home->callback([&session, home_timeout] {
    auto& axis = session.axis();
    with_move_report(session, [&] {
      report_move(session, axis.home(session.deadline_in(*home_timeout),
                                     session.wait_options(progress_printer(session))));
    });
  });

  auto a = std::make_shared<MoveArgs>();
  auto* move =
      app.add_subcommand("move", "Run a stored step (--step N) or a direct operation (--to MM)");
  move->add_option("--step", a->step, "Step number 0-63 (IN0-IN5 + DRIVE)")
      ->check(CLI::Range(0, 63));
  move->add_option("--to", a->to, "Target position, mm (direct operation, D9102-D9111 + D9100)");
  move->add_flag("--relative", a->relative, "--to is a distance from the last target (INC)");
  // The defaults in the help are the library's (one set of defaults).
  const auto d = client::default_direct_data();
  move->add_option("--speed", a->speed,
                   fmt::format("Speed, mm/s (1-65535; default {})", d.speed_mm_s));
  move->add_option("--accel", a->accel,
                   fmt::format("Acceleration, mm/s² (1-65535; default {})", d.acceleration_mm_s2));
  move->add_option("--decel", a->decel,
                   fmt::format("Deceleration, mm/s² (1-65535; default {})", d.deceleration_mm_s2));
  move->add_option("--moving-force", a->moving_force,
                   fmt::format("Moving force, % (0-300; default {})", d.moving_force_pct));
  move->add_option("--in-position", a->in_position,
                   fmt::format("In-position width (pushing: distance), mm (default {})",
                               lec::format_mm(d.in_position_001mm)));
  move->add_option("--area", a->area, "AREA output range A:B, mm (default 0:0)");
  move->add_option("--push", a->push, "Pushing force, % (0-100; 0: a positioning move)");
  move->add_option("--trigger", a->trigger, "Trigger level, % (≤ pushing force; default: = it)");
  move->add_option("--push-speed", a->push_speed,
                   fmt::format("Pushing speed, mm/s (default {})", d.pushing_speed_mm_s));
  move->add_flag("--keep", a->keep,
                 "Values not given keep what the controller holds (else: the defaults above); "
                 "the result names them");
  move->add_flag("--no-wait", a->no_wait, "Return right after the start");
  add_deadline_option(move, a->timeout, "Deadline for the move");
  move->callback([&session, a] { run_move(session, *a); });

  auto dir = std::make_shared<std::string>();
  auto jog_for = std::make_shared<Duration>(Duration::zero());
  auto* jog =
      app.add_subcommand("jog", "Jog + or - while held (Enter/Ctrl-C stops) or --for DURATION");
  jog->add_option("direction", *dir, "+ or -")->required();
  add_duration_option(jog, "--for", *jog_for, "Jog for this long, e.g. 500ms (default: while held)",
                      {std::chrono::milliseconds(1), std::chrono::hours(1)}, BareNumber::Seconds)
      ->default_str("");
  jog->callback([&session, dir, jog_for] { run_jog(session, *dir, *jog_for); });

  auto* hold = app.add_subcommand("hold", "HOLD on (decelerate and suspend) or off (resume)");
  hold->add_option("state", *value, "on|off")->required();
  hold->callback([&session, value] {
    const bool on = parse_on_off(*value, "hold");
    session.allow_broadcast();
    if (on && session.options().id != modbus::kBroadcastId)
      return report_stop(session, client::StopKind::Hold);
    session.axis().hold(on);
    say(session,
        on ? "HOLD on (broadcast: no controller answers, nothing is judged)"
           : "HOLD off: operation resumed",
        {{"hold", on}});
  });

  app.add_subcommand("stop",
                     "Decelerating stop (RESET pulse; RESET released first if another client "
                     "left it at 1), judged by the axis: exit 0 only when it is seen at rest")
      ->callback([&session] {
        session.allow_broadcast();
        if (session.options().id != modbus::kBroadcastId)
          return report_stop(session, client::StopKind::Stop);
        session.axis().stop();  // broadcast: no reply, so nothing can be judged
        say(session, "RESET pulse broadcast (no controller answers a broadcast: not judged)");
      });

  app.add_subcommand("reset", "Reset alarms (RESET pulse)")->callback([&session] {
    const auto left = session.axis().reset_alarms();
    if (!left.empty())
      throw client::AlarmError(
          left,
          lec::alarm_after_reset(left, lec::parse_alarm_polarity(session.options().alarm_polarity)
                                           .value_or(lec::AlarmPolarity::ActiveHigh)));
    say(session, "Alarms reset: none active", {{"alarms", nlohmann::json::array()}});
  });
}

}  // namespace lec6::cli
