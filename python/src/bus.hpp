#pragma once
// lec6.Bus: an opened port (or an in-process twin) and the axes on it.

#include <memory>

#include "bindings.hpp"
#include "lec6/lec/alarm_check.hpp"
#include "line.hpp"

namespace lec6::python {

struct Bus {
  std::shared_ptr<SharedLine> line;
  int retries = 2;
  // How its controllers report X4F (bus.axis() may say otherwise per axis).
  lec::AlarmPolarity alarm_polarity = lec::AlarmPolarity::ActiveHigh;
};

// "active-high" / "active-low" (lec --alarm-polarity); InvalidRequest (a
// ValueError) naming the two otherwise.
lec::AlarmPolarity parse_polarity(const std::string& text);

}  // namespace lec6::python
