// lec6.Cycle: a machine cycle file (docs/cycles.md) read and checked, and run
// on buses from Python: the same file, the same checks and the same runner
// (cycle::Runner) as `lec cycle run`. The GIL is released while the cycle
// runs; Ctrl-C, the `cancel` callback or an error in `on_step` stops every
// axis of the cycle (the runner's stop, judged by the axis) before the error
// is raised.

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <map>
#include <memory>

#include "bindings.hpp"
#include "bus.hpp"
#include "lec6/cycle/analysis.hpp"
#include "lec6/cycle/cycle_file.hpp"
#include "lec6/cycle/runner.hpp"

namespace lec6::python {
namespace {

// What run() returns: the report and where its time went.
struct CycleRun {
  cycle::CycleReport report;
  cycle::CycleAnalysis analysis;
};

// A bad file: cycle::CycleError, raised as lec6.CycleError (errors.cpp).
cycle::Cycle load(const py::object& path) {
  return cycle::load_cycle(py::str(py::module_::import("os").attr("fspath")(path)));
}

cycle::Cycle parse(const std::string& text, const std::string& source) {
  return cycle::parse_cycle(text, source);
}

// The bus of every axis, before anything is sent: one Bus carries every axis;
// a dict maps each axis's `line:` ("" for an axis without one) to its Bus.
std::map<std::string, const Bus*> buses_of(const cycle::Cycle& c, py::handle buses) {
  std::map<std::string, const Bus*> out;
  if (py::isinstance<Bus>(buses)) {
    const Bus* b = buses.cast<const Bus*>();
    for (const auto& a : c.axes) out[a.name] = b;
  } else if (!py::isinstance<py::dict>(buses)) {
    throw client::InvalidRequest(
        "buses: expected a lec6.Bus (every axis on it) or a dict of the cycle's lines to "
        "their Bus, e.g. {'/dev/ttyUSB0': bus}");
  }
  const auto d = py::isinstance<py::dict>(buses) ? buses.cast<py::dict>() : py::dict();
  for (const auto& a : c.axes) {
    if (out.count(a.name)) continue;  // one Bus for every axis
    const py::str key(a.line);
    if (!d.contains(key)) {
      std::vector<std::string> given;
      for (auto item : d) given.push_back(py::str(item.first).cast<std::string>());
      throw client::InvalidRequest(
          fmt::format("axis '{}' is on line '{}' ({}:{}): no Bus for it in buses (given: {})",
                      a.name, a.line, c.source, a.mark.line,
                      given.empty() ? "none" : fmt::format("{}", fmt::join(given, ", "))));
    }
    py::object b = d[key];
    if (!py::isinstance<Bus>(b))
      throw client::InvalidRequest(fmt::format("buses['{}']: expected a lec6.Bus", a.line));
    out[a.name] = b.cast<const Bus*>();
  }
  // Two axes of the file on lines given the same Bus, with one ID, would be
  // one carriage driven as two axes.
  std::map<std::pair<const SharedLine*, uint8_t>, std::string> seen;
  for (const auto& a : c.axes) {
    const auto key = std::make_pair(out.at(a.name)->line.get(), a.id);
    if (auto [it, fresh] = seen.emplace(key, a.name); !fresh) {
      throw client::InvalidRequest(
          fmt::format("axes '{}' and '{}' would be one controller: ID {} on the same Bus ({})",
                      it->second, a.name, a.id, out.at(a.name)->line->describe()));
    }
  }
  return out;
}

CycleRun run(const cycle::Cycle& c, py::handle buses, py::object on_step, py::object cancel) {
  const std::map<std::string, const Bus*> bus_of = buses_of(c, buses);
  // Each axis its own Client on its bus's shared line (line.hpp): the
  // cycle's axes on one line take turns on it, as they would on one Master.
  std::vector<std::shared_ptr<SharedLine>> lines;
  std::vector<std::unique_ptr<client::Client>> owned;
  std::map<std::string, client::Client*> clients;
  for (const auto& a : c.axes) {
    const Bus& b = *bus_of.at(a.name);
    if (b.line->closed()) throw client::InvalidRequest("axis '" + a.name + "': its bus is closed");
    lines.push_back(b.line);
    client::ClientOptions o;
    o.id = a.id;
    o.retries = b.retries;
    o.alarm_polarity = b.alarm_polarity;
    owned.push_back(std::make_unique<client::Client>(*b.line, o));
    clients[a.name] = owned.back().get();
  }

  PythonWait wait(py::none(), std::move(cancel));
  std::unique_ptr<py::error_already_set> step_error;
  cycle::RunOptions o;
  o.stop_requested = [&] { return step_error != nullptr || wait.options().cancel(); };
  if (!on_step.is_none()) {
    o.on_step = [&](const cycle::StepReport& s) {
      if (step_error) return;
      py::gil_scoped_acquire gil;
      try {
        on_step(s);
      } catch (py::error_already_set& e) {
        step_error = std::make_unique<py::error_already_set>(std::move(e));
      } catch (const std::exception& e) {
        PyErr_SetString(PyExc_TypeError, fmt::format("on_step: {}", e.what()).c_str());
        step_error = std::make_unique<py::error_already_set>();
      }
    };
  }
  CycleRun out;
  {
    py::gil_scoped_release nogil;
    cycle::Runner runner(c, clients, o);
    out.report = runner.run();
    out.analysis = cycle::analyse(out.report);
  }
  if (step_error) {
    step_error->restore();
    throw py::error_already_set();
  }
  if (wait.has_error()) {
    // What the stops found: at rest, or not seen so (the axes and why).
    std::vector<std::string> moving;
    for (const auto& s : out.report.stood)
      if (!s.stopped) moving.push_back(s.axis + ": " + s.how);
    wait.rethrow(moving.empty()
                     ? "cycle stopped (Ctrl-C): every axis of the cycle was stopped"
                     : fmt::format("cycle stopped (Ctrl-C): a stop was sent to every axis of the "
                                   "cycle; not seen at rest: {}",
                                   fmt::join(moving, "; ")));
  }
  return out;
}

double secs(Duration d) {
  return to_seconds(d);
}

py::object maybe_secs(const std::optional<Duration>& d) {
  return d ? py::cast(to_seconds(*d)) : py::none();
}

void bind_reports(py::module_& m) {
  py::class_<cycle::AxisSpan>(m, "CycleSpan",
                              "One axis's part of a cycle step (or a dwell's: axis ''), in "
                              "seconds from the cycle's start.")
      .def_readonly("axis", &cycle::AxisSpan::axis)
      .def_readonly("what", &cycle::AxisSpan::what)
      .def_property_readonly("start_s", [](const cycle::AxisSpan& s) { return secs(s.start); })
      .def_property_readonly("end_s", [](const cycle::AxisSpan& s) { return secs(s.end); })
      .def_property_readonly(
          "outcome",
          [](const cycle::AxisSpan& s) { return std::string(cycle::outcome_name(s.outcome)); },
          "'reached', 'pushed', 'push_missed', 'alarm', 'done', ... (docs/cycles.md)")
      .def_readonly("detail", &cycle::AxisSpan::detail)
      .def_property_readonly("position_mm",
                             [](const cycle::AxisSpan& s) { return to_mm(s.position_001mm); })
      .def("__repr__", [](const cycle::AxisSpan& s) {
        return fmt::format("CycleSpan('{}', {}, {:.3f}-{:.3f} s)", s.axis,
                           cycle::outcome_name(s.outcome), secs(s.start), secs(s.end));
      });
  py::class_<cycle::StepReport>(m, "CycleStep", "One step of a cycle as it ran.")
      .def_readonly("path", &cycle::StepReport::path, "'3', '4.2 (2/5)', 'no_part.1'")
      .def_readonly("text", &cycle::StepReport::text)
      .def_property_readonly("start_s", [](const cycle::StepReport& s) { return secs(s.start); })
      .def_property_readonly("end_s", [](const cycle::StepReport& s) { return secs(s.end); })
      .def_readonly("axes", &cycle::StepReport::axes)
      .def_readonly("decision", &cycle::StepReport::decision,
                    "'continue', 'branch NAME', 'abort', 'stopped'")
      .def("__repr__", [](const cycle::StepReport& s) {
        return fmt::format("CycleStep('{}', '{}', {:.3f}-{:.3f} s, {})", s.path, s.text,
                           secs(s.start), secs(s.end), s.decision);
      });
  py::class_<cycle::AxisStand>(m, "AxisStand",
                               "Where an axis stood when its cycle was stopped or aborted.")
      .def_readonly("axis", &cycle::AxisStand::axis)
      .def_readonly("stopped", &cycle::AxisStand::stopped, "a read showed it at rest")
      .def_property_readonly(
          "position_mm",
          [](const cycle::AxisStand& s) {
            return s.answered ? py::cast(to_mm(s.position_001mm)) : py::none();
          },
          "None when its controller did not answer")
      .def_readonly("how", &cycle::AxisStand::how)
      .def("__repr__", [](const cycle::AxisStand& s) {
        return fmt::format("AxisStand('{}', stopped={}, {})", s.axis, s.stopped ? "True" : "False",
                           s.how);
      });
  py::class_<CycleRun>(m, "CycleReport",
                       "What a cycle did: its steps, whether it completed, where each axis stood "
                       "when it was stopped, and where its time went.")
      .def_property_readonly("completed", [](const CycleRun& r) { return r.report.completed; })
      .def_property_readonly(
          "ended", [](const CycleRun& r) { return r.report.ended; },
          "why it ended ('completed', 'stopped', an abort's reason)")
      .def_property_readonly("cycle_time_s",
                             [](const CycleRun& r) { return secs(r.report.cycle_time); })
      .def_property_readonly("iterations", [](const CycleRun& r) { return r.report.iterations; })
      .def_property_readonly("steps", [](const CycleRun& r) { return r.report.steps; })
      .def_property_readonly(
          "stood", [](const CycleRun& r) { return r.report.stood; },
          "every axis, when the cycle was stopped or aborted")
      .def_property_readonly(
          "time_split",
          [](const CycleRun& r) {
            return py::dict(py::arg("line") = secs(r.analysis.line),
                            py::arg("motion") = secs(r.analysis.motion),
                            py::arg("program") = secs(r.analysis.program));
          },
          "the cycle time along its critical path, in seconds: the line's share (reads, "
          "starts, completion seen), the axes' motion, dwells and waits (docs/cycles.md)")
      .def_property_readonly(
          "max_start_skew_s",
          [](const CycleRun& r) { return maybe_secs(r.analysis.max_start_skew); },
          "the largest start skew of a parallel group of motions, or None")
      .def("__repr__", [](const CycleRun& r) {
        return fmt::format("CycleReport(completed={}, {:.3f} s, {} steps, '{}')",
                           r.report.completed ? "True" : "False", secs(r.report.cycle_time),
                           r.report.steps.size(), r.report.ended);
      });
}

}  // namespace

void bind_cycle(py::module_& m) {
  bind_reports(m);
  py::class_<cycle::Cycle>(m, "Cycle",
                           "A machine cycle (docs/cycles.md): lec6.Cycle('cell.yaml') reads and "
                           "checks the file (lec6.CycleError names its line, column, field and "
                           "rule), .run(bus) runs it.")
      .def(py::init(&load), py::arg("path"))
      .def_static("from_yaml", &parse, py::arg("text"), py::arg("source") = "<string>",
                  "A cycle from YAML text; `source` names it in errors.")
      .def_readonly("name", &cycle::Cycle::name)
      .def_readonly("source", &cycle::Cycle::source)
      .def_readonly("repeat", &cycle::Cycle::repeat)
      .def_property_readonly(
          "axes",
          [](const cycle::Cycle& c) {
            py::dict d;
            for (const auto& a : c.axes)
              d[py::str(a.name)] = py::dict(py::arg("line") = a.line, py::arg("id") = a.id);
            return d;
          },
          "{name: {'line': ..., 'id': ...}}")
      .def(
          "run",
          [](const cycle::Cycle& c, py::object buses, py::object on_step, py::object cancel) {
            return run(c, buses, std::move(on_step), std::move(cancel));
          },
          py::arg("buses"), py::kw_only(), py::arg("on_step") = py::none(),
          py::arg("cancel") = py::none(),
          "Runs the cycle: `buses` is a lec6.Bus that carries every axis, or a dict of the "
          "file's lines ('' for an axis without `line:`) to their Bus. Interlocks are checked "
          "before every step that moves; an outcome that aborts, `cancel()` returning True, "
          "Ctrl-C or an error raised by `on_step(step)` stops every axis (.stood says where "
          "each stood). Returns a CycleReport; Ctrl-C and on_step's errors are raised after "
          "the axes were stopped.")
      .def("__repr__", [](const cycle::Cycle& c) {
        return fmt::format("Cycle('{}', {} axes, from {})", c.name, c.axes.size(), c.source);
      });
}

}  // namespace lec6::python
