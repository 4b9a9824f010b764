#pragma once
// lec6.Bus: an opened port (or an in-process twin) and the axes on it.

#include <memory>

#include "bindings.hpp"
#include "line.hpp"

namespace lec6::python {

struct Bus {
  std::shared_ptr<SharedLine> line;
  int retries = 2;
};

}  // namespace lec6::python
