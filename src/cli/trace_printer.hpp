#pragma once
// `--trace`: one line per frame on stderr, with time, direction, hex and meaning.

#include "lec6/client/client.hpp"

namespace lec6::cli {

void print_trace_event(const client::TraceEvent& e);

}  // namespace lec6::cli
