#pragma once
// lec6.Axis: one controller ID on a shared bus. Every call builds its own
// Client and Actuator (a few words, no I/O) on the shared line, so an Axis can
// be used from several threads at once: their transactions take turns on the
// line (line.hpp).

#include <memory>
#include <optional>

#include "bindings.hpp"
#include "line.hpp"

namespace lec6::python {

struct Axis {
  std::shared_ptr<SharedLine> line;
  client::ClientOptions options;  // id, retries
  std::optional<client::SoftLimits> soft_limits;  // axis.soft_limits = (min_mm, max_mm)

  uint8_t id() const { return options.id; }

  // Runs f(client, actuator) with the GIL released.
  template <typename F>
  auto call(F&& f) {
    std::shared_ptr<SharedLine> keep = line;  // a close() elsewhere must not free it under us
    py::gil_scoped_release nogil;
    client::Client c(*keep, options);
    client::Actuator a(c);
    a.set_soft_limits(soft_limits);
    struct Count {  // also when f throws: a failed call's retries count too
      SharedLine& line;
      client::Client& c;
      ~Count() {
        const auto s = c.stats();
        const auto m = line.stats();
        line.count(s.retries - m.retries, s.exceptions - m.exceptions);
      }
    } count{*keep, c};
    return f(c, a);
  }

  // Like call(), for an operation that waits: f(client, actuator,
  // WaitOptions). Ctrl-C and the callbacks end the wait (wait.cpp); their
  // Python error is raised with `interrupted` as a KeyboardInterrupt's text.
  template <typename F>
  auto wait_call(py::object progress, py::object cancel, const std::string& interrupted, F&& f) {
    PythonWait wait(std::move(progress), std::move(cancel));
    try {
      auto result =
          call([&](client::Client& c, client::Actuator& a) { return f(c, a, wait.options()); });
      if (wait.has_error()) wait.rethrow(interrupted);  // a jog ends normally when cancelled
      return result;
    } catch (const client::Cancelled& e) {
      if (wait.has_error()) wait.rethrow(interrupted);
      throw;
    }
  }
};

// axis.cpp: the class with status and motion; steps.cpp adds the step table.
void bind_axis(py::module_& m);
void add_step_methods(py::class_<Axis>& axis);

}  // namespace lec6::python
