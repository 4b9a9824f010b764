#pragma once
// The `lec6._lec6` extension: a thin layer over the C++ library. Each file
// binds one part; this header is what they share.
//
// Rules every binding keeps:
//  - the GIL is released around every call that talks to a controller
//    (Axis::call), and re-acquired only to run Python callbacks;
//  - values are checked in C++ (lec::parse_field, lec::validate) before
//    anything is sent, and C++ exceptions become lec6.* exceptions in one
//    place (errors.cpp);
//  - units are the manual's: mm as float, mm/s, mm/s², % as int.

#include <pybind11/functional.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lec6/client/actuator.hpp"
#include "lec6/client/shared_master.hpp"
#include "lec6/lec/alarms.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/lec/state_data.hpp"
#include "lec6/lec/step_data.hpp"

namespace lec6::python {

namespace py = pybind11;

void bind_errors(py::module_& m);
void bind_records(py::module_& m);
void bind_steps(py::module_& m);
void bind_bus(py::module_& m);
void bind_twin(py::module_& m);
void bind_cycle(py::module_& m);

// ---- errors (errors.cpp) ------------------------------------------------------

// Raises lec6.<name>(message) with extra attributes; never returns.
[[noreturn]] void raise_error(const char* name, const std::string& message,
                              const py::dict& attributes = {});
// The Python exception object for a C++ exception (as the translator maps it).
py::object python_exception(std::exception_ptr error);

// ---- values (values.cpp) ------------------------------------------------------

// A Python value for a step field (int, float, or text as typed), checked by
// lec::parse_field against the manual's range. `keyword` names it in the
// message when it differs from the field's name ("to" for position).
// Throws client::InvalidRequest (lec6.InvalidRequest, a ValueError).
int64_t field_value(lec::StepField field, py::handle value, std::string_view keyword);

// A value in mm (float) from 0.01 mm.
inline double to_mm(int64_t value_001mm) {
  return static_cast<double>(value_001mm) / 100.0;
}

// Seconds as a Duration; ValueError unless finite and > 0.
Duration seconds_arg(double seconds, std::string_view keyword);

// ---- records (records.cpp) ----------------------------------------------------

// What status() returns: the state (D9000–D9006), the flags (X40–X4F) and
// the alarms active when it was read.
struct Status {
  lec::StateData state;
  lec::StatusFlags flags;
  std::vector<uint8_t> alarms;
  bool operator==(const Status&) const = default;
};

struct Alarm {
  uint8_t code = 0;
  bool operator==(const Alarm&) const = default;
};

// A finished operation: client::MoveResult and what it was.
struct MoveResult {
  client::MoveResult result;
  std::string operation;  // "move", "step 3", "home", "jog"
  bool waited = true;     // false: move(wait=False), the status right after the start
  // move(wait=False): what Axis.wait() judges the move against, and the axis
  // (its line and ID) that started it.
  std::optional<client::StartedMove> started{};
  std::weak_ptr<client::SharedMaster> line{};  // the bus's line: not kept open by a result
  uint8_t id = 0;
};

// ---- waiting (wait.cpp) -------------------------------------------------------

// client::WaitOptions for a call made with the GIL released: Ctrl-C
// (SIGINT, main thread only) and the caller's `cancel` end the wait (the
// Actuator then stops the axis), `progress` sees every poll. Python errors
// raised there (KeyboardInterrupt, or one from a callback) are kept and
// raised after the C++ call returned (rethrow()). Construct and destroy with
// the GIL held.
class PythonWait {
 public:
  PythonWait(py::object progress, py::object cancel);
  ~PythonWait();
  PythonWait(const PythonWait&) = delete;
  PythonWait& operator=(const PythonWait&) = delete;

  const client::WaitOptions& options() const { return options_; }
  // True when a Python error ended the wait (Ctrl-C or a callback).
  bool has_error() const { return static_cast<bool>(error_); }
  // With the GIL: raises the kept error. A KeyboardInterrupt gets `what`
  // ("...: the axis was stopped") as its message.
  [[noreturn]] void rethrow(const std::string& what);

 private:
  bool cancel_requested();
  void report(const client::Progress& p);

  py::object progress_, cancel_;
  bool main_thread_;
  TimePoint next_signal_check_{};
  std::unique_ptr<py::error_already_set> error_;
  client::WaitOptions options_;
};

}  // namespace lec6::python
