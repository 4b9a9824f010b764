#pragma once
// What `lec cycle run` prints: each step as it ends (per axis start/end,
// outcome, position), the end (cycle time, where each axis stood), and the
// JUnit XML of --junit.

#include <optional>
#include <string>

#include "lec6/cycle/runner.hpp"

namespace lec6::cli {

// "step 2  push z to down (80.00 mm)  1.602 -> 2.410 s  continue" and a line per axis.
std::string format_step(const cycle::StepReport& step);
// "cycle completed in 4.321 s (simulated time), 1 pass" and, after a stop or
// an abort, where each axis stood.
std::string format_end(const cycle::CycleReport& report, bool simulated);
// The report as JSON (--json).
std::string report_json(const cycle::CycleReport& report, bool simulated);
// JUnit XML: one test case per assertion (the cycle completes, every push
// found its workpiece, no interlock refused, the cycle time under the limit
// when given).
std::string junit_xml(const std::string& cycle_name, const cycle::CycleReport& report,
                      std::optional<Duration> max_cycle_time);

}  // namespace lec6::cli
