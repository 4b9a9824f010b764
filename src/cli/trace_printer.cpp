#include "cli/trace_printer.hpp"

#include <fmt/format.h>

namespace lec6::cli {

void print_trace_event(const client::TraceEvent& e) {
  static const TimePoint first = e.at;
  fmt::print(stderr, "{:10.3f} ms {} {}  | {}\n", to_ms(e.at - first), e.outgoing ? "->" : "<-",
             modbus::to_hex(e.bytes), e.explanation);
}

}  // namespace lec6::cli
