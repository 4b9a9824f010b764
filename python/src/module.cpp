// The `lec6._lec6` extension module; `lec6/__init__.py` re-exports it.

#include "bindings.hpp"

PYBIND11_MODULE(_lec6, m) {
  using namespace lec6::python;
  m.doc() = "lec6: SMC LEC6 controllers (LECP6, LECA6) over Modbus RTU, from Python.";
  m.attr("__version__") = LEC6_VERSION;
  bind_errors(m);
  bind_records(m);
  bind_steps(m);
  bind_bus(m);
  bind_twin(m);
  bind_cycle(m);
}
