#pragma once
// One run of a machine cycle on lec serve's lines (the rules:
// cycle_service.hpp): cycle::Runner over a LineMaster per line and a Client
// per axis, ending on any stop of its axes.

#include <functional>
#include <map>
#include <string>

#include "cycles/served_cycle.hpp"
#include "ops/axis_directory.hpp"
#include "ops/operations.hpp"

namespace lec6::serve {

// `axes`: lec serve's axis of each of the cycle's axes, by the cycle's
// name; `asked`: a stop of the cycle was asked for (POST .../stop). The
// result's body is the cycle's report (cycle/report_json.hpp): 200
// completed, 422 stopped or aborted, 502 a line fault.
OpResult run_served_cycle(const ServedCycle& served, const std::map<std::string, AxisRef>& axes,
                          const Operations::Claim& claim, const std::function<bool()>& asked);

}  // namespace lec6::serve
