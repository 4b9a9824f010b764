// Step data as Python objects: Step (one 16-register record, fields named
// like the CLI's CSV columns, in the manual's units), StepTable (the files of
// `lec step backup / restore / diff`, same CSV and JSON formats) and StepDiff.
// Field names, ranges and messages all come from the field table
// (lec/step_data.hpp), so they cannot drift from the CLI's.

#include <fmt/format.h>

#include "bindings.hpp"
#include "lec6/client/errors.hpp"
#include "lec6/client/step_sync.hpp"
#include "lec6/lec/step_assign.hpp"
#include "lec6/lec/step_table.hpp"
#include "lec6/lec/units.hpp"
#include "lec6/transport/step_table_file.hpp"
#include "steps.hpp"

namespace lec6::python {
namespace {

using lec::StepData;
using lec::StepField;
using lec::StepTable;

std::string join(const std::vector<std::string>& lines, std::string_view sep = "; ") {
  std::string out;
  for (const auto& l : lines) out += (out.empty() ? "" : std::string(sep)) + l;
  return out;
}

py::object field_object(const StepData& s, const lec::StepFieldInfo& i) {
  const int64_t v = lec::get_field(s, i.field);
  if (i.field == StepField::MovementMode) return py::str(lec::format_field(i.field, v));
  if (i.is_length) return py::float_(to_mm(v));
  return py::int_(v);
}

// Applies keyword fields to a record: any name find_step_field knows (CSV
// column, CLI name, the manual's name); each value checked by parse_field.
StepData with_fields(StepData s, const py::kwargs& fields) {
  for (auto item : fields) {
    const std::string name = py::str(item.first);
    const auto* info = lec::find_step_field(name);
    if (!info) throw client::InvalidRequest(lec::unknown_field_message(name));
    lec::set_field(s, info->field, field_value(info->field, item.second, name));
  }
  return s;
}

void check_record(const StepData& s, std::string_view what) {
  std::vector<std::string> problems;
  for (const auto& issue : lec::validate(s)) problems.push_back(issue.message);
  if (!problems.empty()) throw client::InvalidRequest(fmt::format("{}: {}", what, join(problems)));
}

std::string step_repr(const StepData& s) {
  if (s.is_blank()) return "Step.blank()";
  std::string out;
  for (const auto& i : lec::step_fields()) {
    const std::string v = lec::format_field(i.field, lec::get_field(s, i.field));
    out += fmt::format("{}{}={}", out.empty() ? "" : ", ", i.csv_column,
                       i.field == StepField::MovementMode ? "'" + v + "'" : v);
  }
  return "Step(" + out + ")";
}

void check_step_number(int n) {
  if (n < 0 || n >= static_cast<int>(StepTable::kSteps))
    throw py::key_error(fmt::format("step {}: steps are numbered 0 to 63", n));
}

[[noreturn]] void table_errors(const std::string& where, const lec::TableErrors& errors) {
  raise_error("InvalidRequest",
              fmt::format("{}: {} error{}:\n  {}", where, errors.size(),
                          errors.size() == 1 ? "" : "s", join(errors, "\n  ")),
              py::dict(py::arg("errors") = errors));
}

void bind_step(py::module_& m) {
  py::class_<StepData> c(m, "Step",
                         "One step-data record (D0400 + 16 n) or direct-operation data, in the "
                         "manual's units. Step(**fields) starts from gentle defaults (speed 100 "
                         "mm/s, accel/decel 1000 mm/s², in position 0.50 mm) and checks every "
                         "field against the manual's ranges.");
  c.def(py::init([](const py::kwargs& fields) {
     StepData s = with_fields(client::default_direct_data(), fields);
     check_record(s, "Step");
     return s;
   }))
      .def_static(
          "blank", [] { return StepData{}; }, "A blank (unregistered) step: all zeros.")
      .def_property_readonly("is_blank", &StepData::is_blank)
      .def_property_readonly("is_pushing", &StepData::is_pushing)
      .def(
          "replace",
          [](const StepData& s, const py::kwargs& fields) {
            StepData out = with_fields(s, fields);
            check_record(out, "Step.replace");
            return out;
          },
          "A copy with the given fields changed (checked like Step()).")
      .def(
          "validate",
          [](const StepData& s) {
            std::vector<std::string> out;
            for (const auto& issue : lec::validate(s)) out.push_back(issue.message);
            return out;
          },
          "What the controller would refuse about this record (empty: nothing).")
      .def(
          "to_dict",
          [](const StepData& s) {
            py::dict d;
            for (const auto& i : lec::step_fields()) d[py::str(i.csv_column)] = field_object(s, i);
            return d;
          },
          "The fields by their CSV column names (speed_mm_s, position_mm...), in "
          "the manual's units.")
      .def("__eq__", [](const StepData& a, const StepData& b) { return a == b; })
      .def("__hash__",
           [](const StepData& s) {
             py::tuple t(StepData::kRegisters);
             const auto regs = s.to_registers();
             for (std::size_t i = 0; i < regs.size(); ++i) t[i] = py::int_(regs[i]);
             return py::hash(t);
           })
      .def("__repr__", &step_repr);
  for (const auto& info : lec::step_fields()) {
    const auto* i = &info;
    c.def_property_readonly(
        std::string(i->csv_column).c_str(), [i](const StepData& s) { return field_object(s, *i); },
        fmt::format("{}{}", i->label, i->unit.empty() ? "" : fmt::format(", {}", i->unit)).c_str());
  }
}

std::vector<unsigned> covered(const StepTable& t) {
  return t.covered_steps();
}

void bind_table(py::module_& m) {
  py::class_<StepTable>(m, "StepTable",
                        "Steps as `lec step backup` saves them (CSV or JSON): a subset of the 64 "
                        "steps, the equipment name and controller ID. table[n] is a Step.")
      .def(py::init([](const std::optional<std::map<int, StepData>>& steps,
                       const std::string& equipment_name, int controller_id) {
             StepTable t;
             t.covered.reset();
             if (steps) {
               for (const auto& [n, s] : *steps) {
                 check_step_number(n);
                 t.steps[static_cast<std::size_t>(n)] = s;
                 t.covered.set(static_cast<std::size_t>(n));
               }
             }
             if (controller_id < 0 || controller_id > 255)
               throw client::InvalidRequest("controller_id: 0-255 (0: not recorded)");
             t.equipment_name = equipment_name;
             t.controller_id = static_cast<uint8_t>(controller_id);
             return t;
           }),
           py::arg("steps") = py::none(), py::arg("equipment_name") = "",
           py::arg("controller_id") = 0)
      .def_static(
          "load",
          [](const py::object& path) {
            const std::string p = py::str(py::module_::import("os").attr("fspath")(path));
            auto t = transport::read_table_file(p);
            if (!t) table_errors(p, t.error());
            return *t;
          },
          py::arg("path"),
          "Reads a CSV or JSON file (by extension); InvalidRequest lists every error.")
      .def_static(
          "parse",
          [](const std::string& text, const std::string& format) {
            if (format != "csv" && format != "json")
              throw client::InvalidRequest("format: 'csv' or 'json'");
            auto t = lec::parse_table(
                text, format == "json" ? lec::TableFormat::Json : lec::TableFormat::Csv);
            if (!t) table_errors(format, t.error());
            return *t;
          },
          py::arg("text"), py::arg("format") = "csv",
          "A table from CSV or JSON text in `lec step backup`'s formats; every error of the "
          "text at once (InvalidRequest.errors).")
      .def(
          "save",
          [](const StepTable& t, const py::object& path) {
            const std::string p = py::str(py::module_::import("os").attr("fspath")(path));
            if (auto w = transport::write_table_file(p, t); !w) throw py::value_error(w.error());
          },
          py::arg("path"), "Writes CSV or JSON (by extension), atomically.")
      .def(
          "to_csv", [](const StepTable& t) { return lec::to_csv(t); },
          "The table as `lec step backup file.csv` writes it.")
      .def(
          "to_json", [](const StepTable& t) { return lec::to_json(t); },
          "The table as `lec step backup file.json` writes it.")
      .def_readwrite("equipment_name", &StepTable::equipment_name)
      .def_readwrite("controller_id", &StepTable::controller_id)
      .def_property_readonly("steps", &covered, "The step numbers the table holds.")
      .def("__getitem__",
           [](const StepTable& t, int n) {
             check_step_number(n);
             if (!t.covers(static_cast<std::size_t>(n)))
               throw py::key_error(fmt::format("step {} is not in this table", n));
             return t.steps[static_cast<std::size_t>(n)];
           })
      .def("__setitem__",
           [](StepTable& t, int n, const StepData& s) {
             check_step_number(n);
             t.steps[static_cast<std::size_t>(n)] = s;
             t.covered.set(static_cast<std::size_t>(n));
           })
      .def("__delitem__",
           [](StepTable& t, int n) {
             check_step_number(n);
             t.covered.reset(static_cast<std::size_t>(n));
           })
      .def("__contains__", [](const StepTable& t,
                              int n) { return n >= 0 && t.covers(static_cast<std::size_t>(n)); })
      .def("__len__", [](const StepTable& t) { return t.covered.count(); })
      .def("__iter__", [](const StepTable& t) { return py::iter(py::cast(covered(t))); })
      .def("__eq__", [](const StepTable& a, const StepTable& b) { return a == b; })
      .def(
          "diff",
          [](const StepTable& a, const StepTable& b) {
            return NamedDiff{client::diff_backups(a, b), "a", "b"};
          },
          py::arg("other"), "Differences with another table, for the steps both hold.")
      .def("__repr__", [](const StepTable& t) {
        return fmt::format("StepTable({} steps: {}, equipment_name='{}', controller_id={})",
                           t.covered.count(), client::format_step_list(t.covered_steps()),
                           t.equipment_name, t.controller_id);
      });
}

void bind_diff(py::module_& m) {
  py::class_<lec::StepFieldDiff>(m, "StepFieldDiff", "One field of one step that differs.")
      .def_readonly("step", &lec::StepFieldDiff::step)
      .def_property_readonly("field",
                             [](const lec::StepFieldDiff& d) {
                               return std::string(lec::field_info(d.field).csv_column);
                             })
      .def_readonly("a", &lec::StepFieldDiff::value_a)
      .def_readonly("b", &lec::StepFieldDiff::value_b)
      .def("__repr__", [](const lec::StepFieldDiff& d) {
        return fmt::format("StepFieldDiff(step={}, field='{}', a='{}', b='{}')", d.step,
                           lec::field_info(d.field).csv_column, d.value_a, d.value_b);
      });
  py::class_<NamedDiff>(m, "StepDiff", "Differences between two step tables (a and b).")
      .def_property_readonly("equal", [](const NamedDiff& d) { return d.diff.equal(); })
      .def_property_readonly("differences", [](const NamedDiff& d) { return d.diff.fields; })
      .def_property_readonly(
          "notes", [](const NamedDiff& d) { return d.diff.notes; },
          "Equipment name or controller ID differ (not step data).")
      .def_property_readonly("steps_differing", [](const NamedDiff& d) { return d.diff.steps(); })
      .def("__len__", [](const NamedDiff& d) { return d.diff.fields.size(); })
      .def("__str__",
           [](const NamedDiff& d) {
             std::string notes;
             for (const auto& n : d.diff.notes) notes += "note: " + n + "\n";
             return notes + lec::format_diff_side_by_side(d.diff.fields, d.label_a, d.label_b);
           })
      .def("__repr__", [](const NamedDiff& d) {
        return fmt::format("StepDiff({} fields in {} steps differ)", d.diff.fields.size(),
                           d.diff.steps());
      });
}

}  // namespace

StepTable table_argument(const py::object& source) {
  if (py::isinstance<StepTable>(source)) return source.cast<StepTable>();
  const std::string p = py::str(py::module_::import("os").attr("fspath")(source));
  auto t = transport::read_table_file(p);
  if (!t) table_errors(p, t.error());
  return *t;
}

void bind_steps(py::module_& m) {
  bind_step(m);
  bind_table(m);
  bind_diff(m);
  bind_restore_report(m);
}

}  // namespace lec6::python
