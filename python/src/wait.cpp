// Waiting on the wire with the GIL released, yet interruptible: the
// Actuator polls WaitOptions::cancel between transactions; here that briefly
// takes the GIL to let Python run its signal handlers (Ctrl-C) and the
// caller's callbacks. A Python error there cancels the wait; the Actuator
// then stops the axis (decelerating stop, as `lec` does on Ctrl-C) and throws
// Cancelled, and the binding raises the Python error instead.

#include <fmt/format.h>

#include "bindings.hpp"

namespace lec6::python {
namespace {

// Signals are delivered to the main thread only; checking them costs a GIL
// round trip, so at most this often (Ctrl-C still feels immediate).
constexpr Duration kSignalCheckInterval = std::chrono::milliseconds(20);

bool on_main_thread() {
  // Python ≥ 3.4: the main thread's ident is threading.main_thread().ident.
  static const unsigned long main_ident = [] {
    return py::module_::import("threading")
        .attr("main_thread")()
        .attr("ident")
        .cast<unsigned long>();
  }();
  return PyThread_get_thread_ident() == main_ident;
}

}  // namespace

PythonWait::PythonWait(py::object progress, py::object cancel)
    : progress_(std::move(progress)), cancel_(std::move(cancel)), main_thread_(on_main_thread()) {
  if (!progress_.is_none()) options_.progress = [this](const client::Progress& p) { report(p); };
  options_.cancel = [this] { return cancel_requested(); };
}

PythonWait::~PythonWait() = default;

bool PythonWait::cancel_requested() {
  if (error_) return true;
  const TimePoint now = SteadyClock().now();
  const bool check_signals = main_thread_ && now >= next_signal_check_;
  if (!check_signals && cancel_.is_none()) return false;  // no GIL needed
  py::gil_scoped_acquire gil;
  try {
    if (check_signals) {
      next_signal_check_ = now + kSignalCheckInterval;
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    }
    if (!cancel_.is_none() && cancel_().cast<bool>()) return true;
  } catch (py::error_already_set& e) {
    error_ = std::make_unique<py::error_already_set>(std::move(e));
  } catch (const std::exception& e) {
    // Not a Python error: e.g. a cancel() whose result has no truth value
    // (pybind11's cast_error). It ends the wait like one, so the axis is
    // stopped; escaping from here it skipped the stop (a reviewer's find).
    PyErr_SetString(PyExc_TypeError, fmt::format("cancel: {}", e.what()).c_str());
    error_ = std::make_unique<py::error_already_set>();
  }
  return error_ != nullptr;
}

void PythonWait::report(const client::Progress& p) {
  if (error_) return;
  py::gil_scoped_acquire gil;
  try {
    progress_(Status{p.state, p.flags, {}}, to_seconds(p.elapsed));
  } catch (py::error_already_set& e) {
    error_ = std::make_unique<py::error_already_set>(std::move(e));
  } catch (const std::exception& e) {
    PyErr_SetString(PyExc_TypeError, fmt::format("progress: {}", e.what()).c_str());
    error_ = std::make_unique<py::error_already_set>();
  }
}

void PythonWait::rethrow(const std::string& what) {
  error_->restore();
  error_.reset();
  if (PyErr_ExceptionMatches(PyExc_KeyboardInterrupt)) {
    // Replace Python's bare KeyboardInterrupt with one that says what
    // happened to the axis.
    PyErr_Clear();
    PyErr_SetString(PyExc_KeyboardInterrupt, what.c_str());
  }
  throw py::error_already_set();
}

}  // namespace lec6::python
