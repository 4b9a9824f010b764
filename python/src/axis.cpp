// lec6.Axis: status and the manual's operation sequences (client::Actuator),
// with timeouts in seconds and values in the manual's units.

#include <fmt/format.h>

#include "axis.hpp"
#include "lec6/lec/alarm_check.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::python {
namespace {

using lec::StepField;

constexpr const char* kStopped = "interrupted: the axis was stopped (decelerating stop)";

std::optional<uint16_t> u16(StepField f, const py::object& v, std::string_view keyword) {
  if (v.is_none()) return std::nullopt;
  return static_cast<uint16_t>(field_value(f, v, keyword));
}

std::optional<int32_t> i32(StepField f, const py::object& v, std::string_view keyword) {
  if (v.is_none()) return std::nullopt;
  return static_cast<int32_t>(field_value(f, v, keyword));
}

// The keywords of move(), checked before anything is sent.
struct MoveArgs {
  py::object to, speed, accel, decel, moving_force, in_position, area, push, trigger, push_speed;
  bool relative = false;
  bool keep = false;
};

client::DirectMove direct_move(const MoveArgs& a) {
  client::DirectMove m;
  m.relative = a.relative;
  m.keep = a.keep;
  m.position_001mm = i32(StepField::Position, a.to, "to");
  m.speed_mm_s = u16(StepField::Speed, a.speed, "speed");
  m.acceleration_mm_s2 = u16(StepField::Acceleration, a.accel, "accel");
  m.deceleration_mm_s2 = u16(StepField::Deceleration, a.decel, "decel");
  m.moving_force_pct = u16(StepField::MovingForce, a.moving_force, "moving_force");
  m.in_position_001mm = i32(StepField::InPosition, a.in_position, "in_position");
  m.pushing_force_pct = u16(StepField::PushingForce, a.push, "push");
  m.trigger_level_pct = u16(StepField::TriggerLevel, a.trigger, "trigger");
  m.pushing_speed_mm_s = u16(StepField::PushingSpeed, a.push_speed, "push_speed");
  if (!a.area.is_none()) {
    const auto range = a.area.cast<py::sequence>();
    if (py::isinstance<py::str>(a.area) || range.size() != 2)
      throw client::InvalidRequest("area: expected (end1_mm, end2_mm), e.g. (100.0, 200.0)");
    m.area1_001mm = i32(StepField::Area1, range[0], "area");
    m.area2_001mm = i32(StepField::Area2, range[1], "area");
  }
  // As `lec move` (cmd_motion.cpp): a trigger or pushing speed without a
  // pushing force would be written but never used.
  if (!m.pushing_force_pct && (m.trigger_level_pct || m.pushing_speed_mm_s))
    throw client::InvalidRequest("trigger and push_speed belong to a pushing move: give push too");
  return m;
}

// wait=False: the move as the controller shows it right after the start
// (BUSY may not be up yet: the controller raises it when it acts).
client::MoveResult started_only(const client::StartedMove& started, client::Client& c) {
  client::MoveResult r;
  r.goal = started.start.goal;
  r.started_at = started.start.at;
  r.flags = c.read_flags();  // flags first: the state read after them is as new
  r.state = c.read_state();
  r.in_position = r.flags.inp();
  return r;
}

MoveResult finished(client::MoveResult r, std::string operation, bool waited = true) {
  return MoveResult{std::move(r), std::move(operation), waited};
}

namespace {

// A stop or hold judged by the axis (client/stop.hpp).
py::object judged_stop(Axis& self, client::StopKind kind) {
  const auto r = self.call(
      [kind](client::Client&, client::Actuator& a) { return a.stop(kind, client::StopPolicy{}); });
  if (!r.stopped)
    raise_error("Error", r.describe(),
                py::dict(py::arg("stopped") = false, py::arg("actions") = r.actions));
  return py::str(r.describe());
}
}  // namespace

void bind_reads(py::class_<Axis>& c) {
  c.def(
       "status",
       [](Axis& self) {
         return self.call([](client::Client& cl, client::Actuator& a) {
           Status s;
           s.flags = cl.read_flags();  // flags first: the state read after them is as new
           s.state = cl.read_state();
           s.alarms = a.active_alarms(s.flags);
           return s;
         });
       },
       "Reads the flags (X40-X4F), the state (D9000-D9006) and, when ALARM is on, the active "
       "alarms: 2 transactions (3 with an alarm).")
      .def(
          "read_state",
          [](Axis& self) {
            return self.call([](client::Client& cl, client::Actuator&) { return cl.read_state(); });
          },
          "D9000-D9006 in one transaction.")
      .def(
          "read_flags",
          [](Axis& self) {
            return self.call([](client::Client& cl, client::Actuator&) { return cl.read_flags(); });
          },
          "X40-X4F in one transaction.")
      .def(
          "alarms",
          [](Axis& self) {
            const auto codes = self.call([](client::Client& cl, client::Actuator& a) {
              return a.active_alarms(cl.read_flags());
            });
            std::vector<Alarm> out;
            for (uint8_t code : codes) out.push_back({code});
            return out;
          },
          "The active alarms (empty when ALARM is off).")
      .def(
          "alarm_history",
          [](Axis& self) {
            const auto h =
                self.call([](client::Client& cl, client::Actuator&) { return cl.read_alarms(); });
            std::vector<std::vector<Alarm>> out;
            for (const auto& g : h.groups) {
              std::vector<Alarm> group;
              for (uint8_t code : g.present()) group.push_back({code});
              out.push_back(std::move(group));
            }
            return out;
          },
          "The 16 groups of the alarm history (D0380-D03BF), newest first.")
      .def(
          "name",
          [](Axis& self) {
            return self.call(
                [](client::Client& cl, client::Actuator&) { return cl.read_name().text; });
          },
          "The equipment name (D000E-D0015).");
}

void bind_motion(py::class_<Axis>& c) {
  c.def(
       "set_serial_mode",
       [](Axis& self, bool on) {
         self.call([on](client::Client&, client::Actuator& a) { a.set_serial_mode(on); });
       },
       py::arg("on") = true,
       "Y30: serial input mode (True, needed to operate) or parallel (False).")
      .def(
          "servo_on",
          [](Axis& self, double timeout, py::object progress, py::object cancel) {
            const Duration limit = seconds_arg(timeout, "timeout");
            self.wait_call(progress, cancel, kStopped,
                           [&](client::Client&, client::Actuator& a, const client::WaitOptions& w) {
                             a.servo_on(a.deadline_in(limit), w);
                             return 0;
                           });
          },
          py::kw_only(), py::arg("timeout") = 5.0, py::arg("progress") = py::none(),
          py::arg("cancel") = py::none(), "SVON on, waits for SVRE.")
      .def(
          "servo_off",
          [](Axis& self, double timeout) {
            const Duration limit = seconds_arg(timeout, "timeout");
            self.wait_call(py::none(), py::none(), kStopped,
                           [&](client::Client&, client::Actuator& a, const client::WaitOptions& w) {
                             a.servo_off(a.deadline_in(limit), w);
                             return 0;
                           });
          },
          py::kw_only(), py::arg("timeout") = 5.0, "SVON off, waits for SVRE to fall.")
      .def(
          "home",
          [](Axis& self, double timeout, py::object progress, py::object cancel) {
            const Duration limit = seconds_arg(timeout, "timeout");
            return finished(self.wait_call(progress, cancel, kStopped,
                                           [&](client::Client&, client::Actuator& a,
                                               const client::WaitOptions& w) {
                                             return a.home(a.deadline_in(limit), w);
                                           }),
                            "home");
          },
          py::kw_only(), py::arg("timeout") = 60.0, py::arg("progress") = py::none(),
          py::arg("cancel") = py::none(),
          "Return to origin: SETUP, waits for SETON and BUSY off, clears SETUP.")
      .def(
          "move",
          [](Axis& self, py::object to, bool relative, py::object speed, py::object accel,
             py::object decel, py::object moving_force, py::object in_position, py::object area,
             py::object push, py::object trigger, py::object push_speed, bool keep, bool wait,
             double timeout, py::object progress, py::object cancel) {
            const client::DirectMove m =
                direct_move({to, speed, accel, decel, moving_force, in_position, area, push,
                             trigger, push_speed, relative, keep});
            const Duration limit = seconds_arg(timeout, "timeout");
            std::optional<client::StartedMove> started;
            MoveResult r = finished(self.wait_call(progress, cancel, kStopped,
                                                   [&](client::Client& c, client::Actuator& a,
                                                       const client::WaitOptions& w) {
                                                     if (wait)
                                                       return a.move(m, a.deadline_in(limit), w);
                                                     started = a.start(m);
                                                     return started_only(*started, c);
                                                   }),
                                    "move", wait);
            if (!wait) {
              r.started = started;
              r.line = self.line;
              r.id = self.id();
            }
            return r;
          },
          py::arg("to"), py::kw_only(), py::arg("relative") = false, py::arg("speed") = py::none(),
          py::arg("accel") = py::none(), py::arg("decel") = py::none(),
          py::arg("moving_force") = py::none(), py::arg("in_position") = py::none(),
          py::arg("area") = py::none(), py::arg("push") = py::none(),
          py::arg("trigger") = py::none(), py::arg("push_speed") = py::none(),
          py::arg("keep") = false, py::arg("wait") = true, py::arg("timeout") = 60.0,
          py::arg("progress") = py::none(), py::arg("cancel") = py::none(),
          "Direct operation to `to` mm (a distance with relative=True). Fields not given take "
          "the defaults (100 mm/s, 1000 mm/s², moving force 100 %, in "
          "position 0.50 mm, pushing speed 20 mm/s); keep=True keeps what the controller holds "
          "instead, and the result's message names those values. push=% makes it a pushing "
          "move. Waits for BUSY to fall (wait=False: returns after the start; axis.wait(result) "
          "waits for it later).")
      .def(
          "wait",
          [](Axis& self, const MoveResult& started, double timeout, py::object progress,
             py::object cancel) {
            if (started.waited) return started;  // it ended already: as it ended
            // The bus that started it, still open: a closed bus's line may be
            // freed, and a new one's is another line (another controller).
            const auto line = started.line.lock();
            const bool closed = [&] {
              if (!line) return true;
              py::gil_scoped_release nogil;  // closed() waits for a transaction in progress
              return line->closed();
            }();
            if (!started.started || closed)
              throw client::InvalidRequest(
                  "wait(): the bus this move was started on is closed; wait on the bus that "
                  "started it");
            if (line != self.line || started.id != self.id())
              throw client::InvalidRequest(fmt::format(
                  "wait(): this move was started on axis {}{}; wait for it on that axis",
                  started.id, line == self.line ? "" : " of another bus"));
            const Duration limit = seconds_arg(timeout, "timeout");
            return finished(
                self.wait_call(
                    progress, cancel, kStopped,
                    [&](client::Client&, client::Actuator& a, const client::WaitOptions& w) {
                      return a.wait(*started.started, a.deadline_in(limit), w);
                    }),
                started.operation);
          },
          py::arg("move"), py::kw_only(), py::arg("timeout") = 60.0,
          py::arg("progress") = py::none(), py::arg("cancel") = py::none(),
          "Waits for a move started with move(wait=False) to end, judged as move() judges it "
          "(the same completion rule: BUSY that rises late, a move that ended before the first "
          "poll). Returns its MoveResult; raises as move() does: AlarmError; DeadlineError when "
          "`timeout` passes first (the move goes on: wait again, or stop()); on Ctrl-C or "
          "cancel() the axis is stopped and Cancelled raised. A result that was already waited "
          "for is returned as it is.")
      .def(
          "run_step",
          [](Axis& self, int step, double timeout, py::object progress, py::object cancel) {
            if (step < 0 || step >= static_cast<int>(lec::kStepCount))
              throw client::InvalidRequest(
                  fmt::format("step {}: steps are numbered 0 to 63", step));
            const Duration limit = seconds_arg(timeout, "timeout");
            return finished(
                self.wait_call(
                    progress, cancel, kStopped,
                    [&](client::Client&, client::Actuator& a, const client::WaitOptions& w) {
                      return a.run_step(static_cast<unsigned>(step), a.deadline_in(limit), w);
                    }),
                fmt::format("step {}", step));
          },
          py::arg("step"), py::kw_only(), py::arg("timeout") = 60.0,
          py::arg("progress") = py::none(), py::arg("cancel") = py::none(),
          "Runs stored step 0-63: IN0-IN5, DRIVE, waits for BUSY to fall, DRIVE off.")
      .def(
          "jog",
          [](Axis& self, const std::string& direction, std::optional<double> seconds,
             py::object until, double timeout, py::object progress) {
            if (direction != "+" && direction != "-")
              throw client::InvalidRequest(
                  fmt::format("jog: direction must be '+' or '-', got '{}'", direction));
            if (!seconds && until.is_none())
              throw client::InvalidRequest(
                  "jog: give seconds= or until= (a callable that returns True to stop)");
            const Duration run = seconds ? seconds_arg(*seconds, "seconds") : Duration{};
            const Duration limit = seconds_arg(timeout, "timeout");
            return finished(
                self.wait_call(
                    progress, until, "interrupted: the jog was stopped",
                    [&](client::Client&, client::Actuator& a, const client::WaitOptions& w) {
                      const TimePoint end = seconds ? a.deadline_in(run) : TimePoint::max();
                      const TimePoint deadline =
                          seconds ? end + limit : a.deadline_in(std::chrono::hours(24));
                      return a.jog(direction == "+", end, deadline, w);
                    }),
                "jog");
          },
          py::arg("direction"), py::arg("seconds") = py::none(), py::kw_only(),
          py::arg("until") = py::none(), py::arg("timeout") = 10.0,
          py::arg("progress") = py::none(),
          "JOG+ or JOG- for `seconds`, or until `until()` returns True; then waits for the "
          "axis to stop (at most `timeout` s).")
      .def(
          "hold",
          [](Axis& self, bool on) -> py::object {
            if (!on) {
              self.call([](client::Client&, client::Actuator& a) { a.hold(false); });
              return py::none();
            }
            return judged_stop(self, client::StopKind::Hold);
          },
          py::arg("on") = true,
          "HOLD on: decelerate and suspend, judged by the axis (returns where it was held; "
          "raises lec6.Error when a read does not show it at rest). HOLD off resumes.")
      .def(
          "stop", [](Axis& self) { return judged_stop(self, client::StopKind::Stop); },
          "Decelerating stop (RESET pulse; RESET released first when another client left it at "
          "1), judged by the axis: returns 'stopped at X mm after T s (...)'; raises lec6.Error "
          "with what was sent and what the axis does when it is not seen at rest.")
      .def(
          "reset",
          [](Axis& self) {
            const auto left =
                self.call([](client::Client&, client::Actuator& a) { return a.reset_alarms(); });
            if (!left.empty())
              throw client::AlarmError(left,
                                       lec::alarm_after_reset(left, self.options.alarm_polarity));
          },
          "Resets alarms (RESET pulse); AlarmError if one is still active after it.");
}

}  // namespace

void bind_axis(py::module_& m) {
  py::class_<Axis> c(m, "Axis", "One controller on a bus: lec6.connect(...).axis(id).");
  c.def_property_readonly(
      "alarm_polarity",
      [](const Axis& a) { return std::string(lec::to_string(a.options.alarm_polarity)); },
      "How this controller reports X4F ALARM ('active-high' or 'active-low'): every read of the "
      "flags, status(), alarms() and the waits read ALARM with it.");
  c.def_property_readonly("id", &Axis::id).def("__repr__", [](const Axis& a) {
    return fmt::format("Axis({} on {})", a.id(), a.line->describe());
  });
  c.def_property(
      "soft_limits",
      [](const Axis& a) -> py::object {
        if (!a.soft_limits) return py::none();
        return py::make_tuple(a.soft_limits->min_001mm / 100.0, a.soft_limits->max_001mm / 100.0);
      },
      [](Axis& a, py::object v) {
        if (v.is_none()) return a.soft_limits.reset();
        const auto range = v.cast<py::sequence>();
        if (py::isinstance<py::str>(v) || range.size() != 2)
          throw client::InvalidRequest("soft_limits: expected (min_mm, max_mm), e.g. (0.0, 400.0)");
        const auto lo = static_cast<int32_t>(
            field_value(StepField::Position, py::object(range[0]), "soft_limits"));
        const auto hi = static_cast<int32_t>(
            field_value(StepField::Position, py::object(range[1]), "soft_limits"));
        if (lo > hi) throw client::InvalidRequest("soft_limits: min_mm is above max_mm");
        a.soft_limits = client::SoftLimits{lo, hi};
      },
      "(min_mm, max_mm) or None: moves and steps to a target outside are refused "
      "(lec6.InvalidRequest) before anything is written; the stroke is not in the memory map.");
  bind_reads(c);
  bind_motion(c);
  add_step_methods(c);
}

}  // namespace lec6::python
