// Read-only result objects: State (D9000–D9006), Flags (X40–X4F), Status
// (both, with the active alarms), Alarm and MoveResult. Values in the
// manual's units, flags by the manual's names in lower case; equality and
// hashing by value, like a frozen dataclass.

#include <fmt/format.h>

#include "lec6/client/action_words.hpp"
#include "bindings.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::python {
namespace {

using lec::StateData;
using lec::StatusFlags;

// The state's fields on any class that holds a StateData.
template <typename C, typename Get>
void add_state(C& c, Get get) {
  using T = typename C::type;
  c.def_property_readonly(
       "position_mm", [get](const T& s) { return to_mm(get(s).position_001mm); },
       "Current position, mm (D9000-D9001).")
      .def_property_readonly(
          "speed_mm_s", [get](const T& s) { return get(s).speed_mm_s; },
          "Current speed, mm/s (D9002).")
      .def_property_readonly(
          "thrust_pct", [get](const T& s) { return get(s).thrust_pct; },
          "Current thrust, % (D9003).")
      .def_property_readonly(
          "target_mm", [get](const T& s) { return to_mm(get(s).target_001mm); },
          "Target position, mm (D9004-D9005).")
      .def_property_readonly(
          "step", [get](const T& s) { return get(s).step_no; },
          "Driving or completed step No. (D9006).");
}

// The flags as booleans named like the manual (lower case), on any class
// that holds a StatusFlags.
template <typename C, typename Get>
void add_flags(C& c, Get get) {
  using T = typename C::type;
  struct Named {
    const char* name;
    StatusFlags::Bit bit;
    const char* doc;
  };
  static constexpr Named kFlags[] = {
      {"busy", StatusFlags::Busy, "X48 BUSY: the actuator is operating."},
      {"svre", StatusFlags::Svre, "X49 SVRE: servo is on."},
      {"seton", StatusFlags::Seton, "X4A SETON: return to origin done."},
      {"inp", StatusFlags::Inp, "X4B INP: in position (pushing: thrust reached the trigger)."},
      {"area", StatusFlags::Area, "X4C AREA: within the step's area output range."},
      {"warea", StatusFlags::Warea, "X4D WAREA: within the W-AREA setting."},
      {"estop", StatusFlags::Estop, "X4E ESTOP: emergency stop active."},
      {"alarm", StatusFlags::Alarm, "X4F ALARM: an alarm is active."},
  };
  for (const auto& f : kFlags) {
    const auto bit = f.bit;
    c.def_property_readonly(
        f.name, [get, bit](const T& s) { return get(s).test(bit); }, f.doc);
  }
  c.def_property_readonly(
       "out", [get](const T& s) { return get(s).out(); },
       "OUT0-OUT5: the number of the step that was started.")
      .def_property_readonly(
          "bits", [get](const T& s) { return get(s).bits; }, "X40-X4F as one int (bit 0 = X40).");
}

std::string state_fields(const StateData& s) {
  return fmt::format("position_mm={}, speed_mm_s={}, thrust_pct={}, target_mm={}, step={}",
                     lec::format_mm(s.position_001mm), s.speed_mm_s, s.thrust_pct,
                     lec::format_mm(s.target_001mm), s.step_no);
}

std::string flags_text(const StatusFlags& f) {
  std::string t = f.describe();
  if (f.out() != 0 && t.find("OUT") == std::string::npos) t += fmt::format(" OUT={}", f.out());
  return t;
}

std::string alarms_repr(const std::vector<uint8_t>& codes) {
  std::string out;
  for (uint8_t c : codes) out += fmt::format("{}{}", out.empty() ? "" : ", ", c);
  return "[" + out + "]";
}

py::dict state_dict(const StateData& s) {
  return py::dict(py::arg("position_mm") = to_mm(s.position_001mm),
                  py::arg("speed_mm_s") = s.speed_mm_s, py::arg("thrust_pct") = s.thrust_pct,
                  py::arg("target_mm") = to_mm(s.target_001mm), py::arg("step") = s.step_no);
}

py::dict flags_dict(const StatusFlags& f) {
  return py::dict(
      py::arg("busy") = f.busy(), py::arg("svre") = f.svre(), py::arg("seton") = f.seton(),
      py::arg("inp") = f.inp(), py::arg("area") = f.area(), py::arg("warea") = f.warea(),
      py::arg("estop") = f.estop(), py::arg("alarm") = f.alarm(), py::arg("out") = f.out());
}

// The Actuator's outcome (client/move_result.hpp); "running" for a move
// that was only started (wait=False).
std::string outcome(const MoveResult& r) {
  if (!r.waited) return "running";
  return std::string(client::outcome_name(r.result.outcome));
}

py::object seconds_or_none(const std::optional<Duration>& d) {
  if (!d) return py::none();
  return py::float_(to_seconds(*d));
}

// A hashable tuple of integers (lists are not hashable).
template <typename Range>
py::tuple int_tuple(const Range& values) {
  py::tuple t(values.size());
  std::size_t i = 0;
  for (auto v : values) t[i++] = py::int_(v);
  return t;
}

}  // namespace

void bind_records(py::module_& m) {
  py::class_<Alarm>(m, "Alarm", "An alarm code with its meaning (manual's alarm list).")
      .def(py::init([](int code) {
             if (code < 0 || code > 255) throw py::value_error("alarm code: 0-255");
             return Alarm{static_cast<uint8_t>(code)};
           }),
           py::arg("code"))
      .def_property_readonly("code", [](const Alarm& a) { return a.code; })
      .def_property_readonly("meaning",
                             [](const Alarm& a) { return std::string(lec::alarm_meaning(a.code)); })
      .def_property_readonly(
          "resettable", [](const Alarm& a) { return lec::alarm_resettable(a.code); },
          "Whether reset() clears it.")
      .def("__eq__", [](const Alarm& a, const Alarm& b) { return a == b; })
      .def("__hash__", [](const Alarm& a) { return py::hash(py::int_(a.code)); })
      .def("__int__", [](const Alarm& a) { return a.code; })
      .def("__repr__", [](const Alarm& a) {
        return fmt::format("Alarm({}: {})", a.code, lec::alarm_meaning(a.code));
      });

  auto state = py::class_<StateData>(m, "State", "State data D9000-D9006, in the manual's units.");
  add_state(state, [](const StateData& s) -> const StateData& { return s; });
  state.def("__eq__", [](const StateData& a, const StateData& b) { return a == b; })
      .def("__hash__", [](const StateData& s) { return py::hash(int_tuple(s.to_registers())); })
      .def("to_dict", &state_dict)
      .def("__repr__", [](const StateData& s) { return "State(" + state_fields(s) + ")"; });

  auto flags = py::class_<StatusFlags>(m, "Flags", "Status flags X40-X4F by the manual's names.");
  add_flags(flags, [](const StatusFlags& f) -> const StatusFlags& { return f; });
  flags.def("__eq__", [](const StatusFlags& a, const StatusFlags& b) { return a == b; })
      .def("__hash__", [](const StatusFlags& f) { return py::hash(py::int_(f.bits)); })
      .def("to_dict", &flags_dict)
      .def("__str__", &flags_text)
      .def("__repr__", [](const StatusFlags& f) { return "Flags(" + flags_text(f) + ")"; });

  auto status = py::class_<Status>(
      m, "Status",
      "What axis.status() read: state data, status flags and the active alarms, in the "
      "manual's units and names.");
  add_state(status, [](const Status& s) -> const StateData& { return s.state; });
  add_flags(status, [](const Status& s) -> const StatusFlags& { return s.flags; });
  status.def_property_readonly("state", [](const Status& s) { return s.state; })
      .def_property_readonly("flags", [](const Status& s) { return s.flags; })
      .def_property_readonly(
          "alarms",
          [](const Status& s) {
            std::vector<Alarm> out;
            for (uint8_t c : s.alarms) out.push_back({c});
            return out;
          },
          "The active alarms (history group 0) when ALARM is on; else empty.")
      .def("__eq__", [](const Status& a, const Status& b) { return a == b; })
      .def("__hash__",
           [](const Status& s) {
             return py::hash(py::make_tuple(int_tuple(s.state.to_registers()), s.flags.bits,
                                            int_tuple(s.alarms)));
           })
      .def("to_dict",
           [](const Status& s) {
             py::dict d = state_dict(s.state);
             for (auto item : flags_dict(s.flags)) d[item.first] = item.second;
             d["alarms"] = std::vector<int>(s.alarms.begin(), s.alarms.end());
             return d;
           })
      .def("__repr__", [](const Status& s) {
        return fmt::format("Status({}, flags='{}', alarms={})", state_fields(s.state),
                           flags_text(s.flags), alarms_repr(s.alarms));
      });

  py::class_<MoveResult>(m, "MoveResult", "How an operation ended, and the status then.")
      .def_property_readonly("operation", [](const MoveResult& r) { return r.operation; })
      .def_property_readonly(
          "in_position", [](const MoveResult& r) { return r.result.in_position; },
          "INP when the move ended.")
      .def_property_readonly(
          "outcome", [](const MoveResult& r) { return outcome(r); },
          "'reached', 'pushed', 'push_missed' or 'stopped' (alarms, deadlines and starts the "
          "controller never acted on raise); 'running' for move(wait=False).")
      .def_property_readonly(
          "succeeded", [](const MoveResult& r) { return r.waited && r.result.succeeded(); },
          "True for 'reached' and 'pushed'.")
      .def_property_readonly(
          "evidence", [](const MoveResult& r) { return r.result.evidence; },
          "What showed that the controller started the move (e.g. 'BUSY').")
      .def(
          "describe",
          [](const MoveResult& r) {
            return client::in_terms_of(r.result.describe(), client::Interface::Python);
          },
          "One line in the manual's words, as `lec move` prints it.")
      .def_property_readonly("status",
                             [](const MoveResult& r) {
                               return Status{r.result.state, r.result.flags, {}};
                             })
      .def_property_readonly(
          "position_mm", [](const MoveResult& r) { return to_mm(r.result.state.position_001mm); })
      .def_property_readonly(
          "elapsed_s", [](const MoveResult& r) { return to_seconds(r.result.elapsed); },
          "From the start until completion was seen, s.")
      .def_property_readonly(
          "timeline",
          [](const MoveResult& r) {
            const auto& t = r.result.timeline;
            return py::dict(py::arg("busy_up_s") = seconds_or_none(t.busy_up),
                            py::arg("busy_down_s") = seconds_or_none(t.busy_down),
                            py::arg("inp_s") = seconds_or_none(t.inp));
          },
          "When the polls first saw BUSY rise, BUSY fall and INP, s from the start (None: not "
          "seen).")
      .def("__repr__", [](const MoveResult& r) {
        return fmt::format("MoveResult({}, outcome='{}', position_mm={}, elapsed_s={:.3f})",
                           r.operation, outcome(r), lec::format_mm(r.result.state.position_001mm),
                           to_seconds(r.result.elapsed));
      });
}

}  // namespace lec6::python
