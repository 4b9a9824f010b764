// lec6.Error and its subclasses, and the one translator from the library's
// C++ exceptions to them (client/errors.hpp, client/link.hpp).

#include <fmt/format.h>

#include "bindings.hpp"
#include "lec6/client/action_words.hpp"
#include "lec6/client/errors.hpp"
#include "lec6/client/link.hpp"
#include "lec6/cycle/cycle_file.hpp"
#include "lec6/twin/field_profile.hpp"

namespace lec6::python {
namespace {

struct ErrorClass {
  const char* name;
  const char* base;  // another entry, or nullptr for lec6.Error's Exception
  const char* doc;
};

// Order matters: a class comes after its base.
constexpr ErrorClass kClasses[] = {
    {"Error", nullptr, "Base class of every error lec6 raises."},
    {"TransportError", "Error",
     "The line failed: port missing or busy, no reply (timeout), CRC, framing, echo mismatch. "
     "`.kind` names which ('timeout', 'CRC', 'port', ...)."},
    {"ControllerException", "Error",
     "The controller answered with a Modbus exception (01/02/03). `.code` is the code."},
    {"AlarmError", "Error",
     "The controller raised an alarm (X4F ALARM). `.codes` are the active alarm codes, "
     "`.alarms` the same as lec6.Alarm objects."},
    {"DeadlineError", "Error", "An operation did not finish before its timeout."},
    {"InvalidRequest", "Error",
     "A request refused before anything was sent: a value outside the manual's range (the "
     "message names the field and the range), a step file with errors (`.errors`), a command "
     "the controller's mode does not allow. Also a ValueError."},
    {"MoveNotStarted", "Error",
     "Nothing showed that the controller started the move (no BUSY edge, no target or step "
     "change) within the start window; the axis was sent a stop. `.result` is the MoveResult "
     "(its timeline shows what the polls saw). Never taken for success."},
    {"Cancelled", "Error",
     "An operation was cancelled by its `cancel` callback; the axis was stopped first."},
    {"CycleError", "InvalidRequest",
     "A cycle file that breaks a rule (docs/cycles.md), found before anything moved: "
     "`.file`, `.line`, `.column`, `.field` and `.rule` say where and which. Also a ValueError."},
    {"VerifyError", "Error",
     "A step written to the controller read back different from what was written."},
};

// name → class, filled at import. Never destroyed: it must not outlive the
// interpreter's finalisation with references to drop.
py::dict& classes() {
  static auto* d = new py::dict();
  return *d;
}

py::object error_class(const char* name) {
  return classes()[name];
}

py::object make(const char* name, const std::string& message, const py::dict& attributes) {
  // The library's advice names `lec` commands: a script gets the method.
  py::object e = error_class(name)(client::in_terms_of(message, client::Interface::Python));
  for (auto item : attributes) e.attr(item.first) = item.second;
  return e;
}

py::list alarm_list(const std::vector<uint8_t>& codes) {
  py::list out;
  for (uint8_t c : codes) out.append(py::cast(Alarm{c}));
  return out;
}

std::string_view link_error_name(client::LinkErrorKind k) {
  switch (k) {
    case client::LinkErrorKind::PortUnavailable:
      return "port";
    case client::LinkErrorKind::PortLost:
      return "port lost";
    case client::LinkErrorKind::EchoMismatch:
      return "echo mismatch";
    case client::LinkErrorKind::Io:
      return "io";
  }
  return "io";
}

// The MoveResult an error that ended a move carries, or None.
py::object result_of(const client::WithMoveResult& e) {
  if (!e.move_result()) return py::none();
  return py::cast(MoveResult{*e.move_result(), "move"});
}

py::object translate(std::exception_ptr p) {
  try {
    std::rethrow_exception(p);
  } catch (const client::TransportError& e) {
    return make("TransportError", e.what(),
                py::dict(py::arg("kind") = std::string(client::transport_error_name(e.kind()))));
  } catch (const client::LinkError& e) {
    return make("TransportError", e.what(),
                py::dict(py::arg("kind") = std::string(link_error_name(e.kind()))));
  } catch (const client::ControllerException& e) {
    return make("ControllerException", e.what(),
                py::dict(py::arg("code") = static_cast<int>(e.code())));
  } catch (const client::AlarmError& e) {
    return make(
        "AlarmError", e.what(),
        py::dict(py::arg("codes") = std::vector<int>(e.codes().begin(), e.codes().end()),
                 py::arg("alarms") = alarm_list(e.codes()), py::arg("result") = result_of(e)));
  } catch (const client::MoveNotStarted& e) {
    return make("MoveNotStarted", e.what(), py::dict(py::arg("result") = result_of(e)));
  } catch (const client::DeadlineError& e) {
    return make("DeadlineError", e.what(), py::dict(py::arg("result") = result_of(e)));
  } catch (const client::Cancelled& e) {
    return make("Cancelled", e.what(), py::dict(py::arg("result") = result_of(e)));
  } catch (const cycle::CycleError& e) {
    return make("CycleError", e.what(),
                py::dict(py::arg("file") = e.file(), py::arg("line") = e.at().line,
                         py::arg("column") = e.at().column, py::arg("field") = e.field(),
                         py::arg("rule") = e.rule(), py::arg("errors") = py::list()));
  } catch (const lec6::InvalidArgument& e) {  // InvalidRequest, port specs, twin settings, profiles
    return make("InvalidRequest", e.what(), py::dict(py::arg("errors") = py::list()));
  } catch (const std::invalid_argument& e) {
    return make("InvalidRequest", e.what(), py::dict(py::arg("errors") = py::list()));
  }
}

}  // namespace

void raise_error(const char* name, const std::string& message, const py::dict& attributes) {
  py::object e = make(name, message, attributes);
  PyErr_SetObject(error_class(name).ptr(), e.ptr());
  throw py::error_already_set();
}

py::object python_exception(std::exception_ptr error) {
  if (!error) return make("Error", "failed", {});
  try {
    return translate(error);
  } catch (const std::exception& e) {
    return make("Error", e.what(), {});
  }
}

void bind_errors(py::module_& m) {
  for (const auto& c : kClasses) {
    py::object base =
        c.base ? error_class(c.base) : py::reinterpret_borrow<py::object>(PyExc_Exception);
    py::tuple bases =
        std::string_view(c.name) == "InvalidRequest"
            ? py::make_tuple(base, py::reinterpret_borrow<py::object>(PyExc_ValueError))
            : py::make_tuple(base);
    const std::string qualified = fmt::format("lec6.{}", c.name);
    PyObject* cls = PyErr_NewExceptionWithDoc(qualified.c_str(), c.doc, bases.ptr(), nullptr);
    if (!cls) throw py::error_already_set();
    py::object obj = py::reinterpret_steal<py::object>(cls);
    classes()[c.name] = obj;
    m.attr(c.name) = obj;
  }
  py::register_exception_translator([](std::exception_ptr p) {
    // translate() rethrows the types it does not know: pybind11's own
    // translators get those.
    py::object e = translate(p);
    PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(e.ptr())), e.ptr());
  });
}

}  // namespace lec6::python
