#pragma once
// What steps.cpp (the records and files) and step_io.cpp (reading and
// writing them on a controller) share.

#include <string>

#include "bindings.hpp"
#include "lec6/client/step_sync.hpp"
#include "lec6/lec/step_table.hpp"

namespace lec6::python {

// A diff with the names of its two sides, for printing.
struct NamedDiff {
  client::StepDiff diff;
  std::string label_a;
  std::string label_b;
};

// A StepTable, or a path (str or os.PathLike) to read one from. A file with
// errors raises InvalidRequest listing every error (nothing is sent).
lec::StepTable table_argument(const py::object& source);

void bind_restore_report(py::module_& m);

}  // namespace lec6::python
