// The step table on a controller: read, write (only what differs, read back),
// backup, restore and diff, as `lec step ...` does them (client/step_sync.hpp).
// A restore that fails part-way raises the error of its failure kind with the
// report attached (`.report`): which steps were written, which were not.

#include <fmt/format.h>

#include "axis.hpp"
#include "lec6/client/errors.hpp"
#include "lec6/lec/step_assign.hpp"
#include "lec6/transport/step_table_file.hpp"
#include "steps.hpp"

namespace lec6::python {
namespace {

using client::RestoreReport;
using client::StepOutcome;
using lec::StepData;

constexpr const char* kRestoreInterrupted =
    "interrupted: the steps not yet written were left as they were (run the restore again to "
    "finish)";

unsigned step_number(int n) {
  if (n < 0 || n >= static_cast<int>(lec::StepTable::kSteps))
    throw client::InvalidRequest(fmt::format("step {}: steps are numbered 0 to 63", n));
  return static_cast<unsigned>(n);
}

py::list results(const RestoreReport& r) {
  py::list out;
  for (const auto& s : r.steps) {
    std::vector<std::string> fields;
    for (auto f : s.change.fields) fields.emplace_back(lec::field_info(f).csv_column);
    out.append(py::dict(py::arg("step") = s.change.step,
                        py::arg("outcome") = std::string(client::outcome_name(s.outcome)),
                        py::arg("fields") = fields, py::arg("error") = s.error,
                        py::arg("maybe_written") = s.maybe_written,
                        py::arg("lost_replies") = s.lost_replies));
  }
  return out;
}

// Raises the error of the report's failure kind, with the report attached.
[[noreturn]] void raise_failure(const RestoreReport& r, PythonWait& wait) {
  if (r.failure == client::FailureKind::Cancelled && wait.has_error())
    wait.rethrow(kRestoreInterrupted);
  std::string why = "failed";
  for (const auto& s : r.steps) {
    if (s.outcome == StepOutcome::Failed) why = fmt::format("step {}: {}", s.change.step, s.error);
  }
  const std::string message = fmt::format(
      "{}; {}; written before the failure: {}; run it again to finish (it writes only "
      "what still differs)",
      why, r.summary(), client::format_step_list(r.steps_with(StepOutcome::Written)));
  py::object e;
  switch (r.failure) {
    case client::FailureKind::Verify:
      e = py::module_::import("lec6._lec6").attr("VerifyError")(message);
      break;
    case client::FailureKind::Cancelled:
      e = py::module_::import("lec6._lec6").attr("Cancelled")(kRestoreInterrupted);
      break;
    default:
      e = python_exception(r.exception);
      e.attr("args") = py::make_tuple(message);
  }
  e.attr("report") = py::cast(r);
  PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(e.ptr())), e.ptr());
  throw py::error_already_set();
}

// Runs apply_restore with Ctrl-C (and `cancel`) stopping it between steps.
RestoreReport apply(Axis& self, const client::RestorePlan& plan, client::ApplyOptions o,
                    py::object cancel) {
  PythonWait wait(py::none(), std::move(cancel));
  o.cancel = wait.options().cancel;
  RestoreReport r =
      self.call([&](client::Client& c, client::Actuator&) { return apply_restore(c, plan, o); });
  if (!r.ok()) raise_failure(r, wait);
  return r;
}

void write_step_method(py::class_<Axis>& c) {
  c.def(
      "write_step",
      [](Axis& self, int n, std::optional<StepData> step, bool verify, const py::kwargs& fields) {
        const unsigned number = step_number(n);
        if (step && !fields.empty())
          throw client::InvalidRequest("write_step: give a Step or fields, not both");
        if (!step && fields.empty())
          throw client::InvalidRequest(
              "write_step: nothing to write: give a Step or fields (e.g. speed_mm_s=500)");
        // Every value is checked before the controller is read or written.
        std::vector<lec::StepAssignment> assignments;
        for (auto item : fields) {
          const std::string name = py::str(item.first);
          const auto* info = lec::find_step_field(name);
          if (!info) throw client::InvalidRequest(lec::unknown_field_message(name));
          assignments.push_back({info->field, field_value(info->field, item.second, name)});
        }
        if (step && !step->is_blank()) {
          if (auto issues = lec::validation_messages(*step, number); !issues.empty())
            throw client::InvalidRequest(issues.front());
        }
        const auto plan = self.call([&](client::Client& cl, client::Actuator&) {
          const StepData current = cl.read_step(number);
          if (step) return client::plan_step(number, current, *step);
          auto result = lec::apply_assignments(number, current, assignments);
          if (!result) {
            std::string all;
            for (const auto& e : result.error()) all += (all.empty() ? "" : "; ") + e;
            throw client::InvalidRequest(all + " (nothing was written)");
          }
          return client::plan_step(number, current, result->step);
        });
        client::ApplyOptions o;
        o.verify = verify;
        return apply(self, plan, o, py::none());
      },
      py::arg("step_no"), py::arg("step") = py::none(), py::kw_only(), py::arg("verify") = true,
      "Writes step `step_no` (0-63): a whole Step, or only the fields given (e.g. "
      "speed_mm_s=500, position_mm=150.0) on top of what the controller holds. Writes only the "
      "registers that differ, then reads them back (verify). Returns the RestoreReport.");
}

}  // namespace

void bind_restore_report(py::module_& m) {
  py::class_<RestoreReport>(m, "RestoreReport", "What a step write or restore did, step by step.")
      .def_property_readonly("ok", &RestoreReport::ok)
      .def_readonly("dry_run", &RestoreReport::dry_run)
      .def_readonly("verified", &RestoreReport::verified)
      .def_readonly("notes", &RestoreReport::notes)
      .def_property_readonly("summary", &RestoreReport::summary, "'3 steps written, 61 unchanged'")
      .def_property_readonly(
          "written", [](const RestoreReport& r) { return r.steps_with(StepOutcome::Written); })
      .def_property_readonly(
          "unchanged", [](const RestoreReport& r) { return r.steps_with(StepOutcome::Unchanged); })
      .def_property_readonly(
          "planned", [](const RestoreReport& r) { return r.steps_with(StepOutcome::Planned); },
          "Dry run: the steps that would be written.")
      .def_property_readonly(
          "failed", [](const RestoreReport& r) { return r.steps_with(StepOutcome::Failed); })
      .def_property_readonly(
          "not_attempted",
          [](const RestoreReport& r) { return r.steps_with(StepOutcome::NotAttempted); })
      .def_property_readonly("results", &results,
                             "Per step: step, outcome, fields changed, error, maybe_written.")
      .def("__repr__",
           [](const RestoreReport& r) { return fmt::format("RestoreReport('{}')", r.summary()); });
}

void add_step_methods(py::class_<Axis>& c) {
  c.def(
       "read_step",
       [](Axis& self, int n) {
         const unsigned number = step_number(n);
         return self.call(
             [number](client::Client& cl, client::Actuator&) { return cl.read_step(number); });
       },
       py::arg("step_no"), "Step data No. 0-63 (one transaction).")
      .def(
          "backup_steps",
          [](Axis& self, const py::object& path) {
            const auto table = self.call(
                [](client::Client& cl, client::Actuator&) { return client::backup_steps(cl); });
            if (!path.is_none()) {
              const std::string p = py::str(py::module_::import("os").attr("fspath")(path));
              if (auto w = transport::write_table_file(p, table); !w)
                throw py::value_error(w.error());
            }
            return table;
          },
          py::arg("path") = py::none(),
          "All 64 steps, the equipment name and the ID, as a StepTable (10 reads + the name); "
          "also saved to `path` (CSV, or JSON for *.json) when given.")
      .def(
          "restore_steps",
          [](Axis& self, const py::object& source, bool verify, bool dry_run, py::object cancel) {
            const lec::StepTable table = table_argument(source);  // checked before any I/O
            const auto plan = self.call([&](client::Client& cl, client::Actuator&) {
              return client::plan_restore(cl, table);
            });
            client::ApplyOptions o;
            o.verify = verify;
            o.dry_run = dry_run;
            return apply(self, plan, o, std::move(cancel));
          },
          py::arg("source"), py::kw_only(), py::arg("verify") = true, py::arg("dry_run") = false,
          py::arg("cancel") = py::none(),
          "Writes the steps of a StepTable or file that differ from the controller's (only the "
          "registers that differ), each read back. Returns the RestoreReport; on a failure raises "
          "its error with `.report`.")
      .def(
          "diff_steps",
          [](Axis& self, const py::object& source) {
            const lec::StepTable table = table_argument(source);
            std::string label = "table";
            if (!py::isinstance<lec::StepTable>(source)) {
              label = py::str(py::module_::import("os.path").attr("basename")(
                  py::module_::import("os").attr("fspath")(source)));
            }
            auto d = self.call([&](client::Client& cl, client::Actuator&) {
              return client::diff_controller(cl, table);
            });
            return NamedDiff{std::move(d), fmt::format("controller {}", self.id()), label};
          },
          py::arg("source"),
          "The controller's steps (a) against a StepTable or file (b), for the steps it holds.");
  write_step_method(c);
}

}  // namespace lec6::python
