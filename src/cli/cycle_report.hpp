#pragma once
// What `lec cycle run` prints: each step as it ends (per axis start/end,
// outcome, position), the end (cycle time, where each axis stood), and the
// JUnit XML of --junit.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "lec6/cycle/analysis.hpp"
#include "lec6/cycle/report_json.hpp"
#include "lec6/cycle/runner.hpp"

namespace lec6::cli {

// What a fault did (TwinFaults), the report as JSON (--json): the cycle
// layer's, which lec serve answers with too.
using cycle::InjectedFault;
using cycle::report_json;

// Escapes &, <, > and " for XML and HTML text and attributes.
std::string xml_escape(std::string_view s);

// "step 2  push z to down (80.00 mm)  1.602 -> 2.410 s  continue" and a line per axis.
std::string format_step(const cycle::StepReport& step);
// "cycle completed in 4.321 s (simulated time), 1 pass" and, after a stop or
// an abort, where each axis stood.
std::string format_end(const cycle::CycleReport& report, bool simulated);
// Where the time went: "motion 9.810 s (74 %), the line 3.190 s (24 %: ...)",
// each line's utilisation, the largest start skew.
std::string format_analysis(const cycle::CycleAnalysis& analysis);
// "step 6 (2/2): z's push at step 6 finds no workpiece: injected"
std::string format_fault(const InjectedFault& f);
// JUnit XML: one test case per assertion (the cycle completes, every push
// found its workpiece, no interlock refused, the cycle time under the limit
// when given).
std::string junit_xml(const std::string& cycle_name, const cycle::CycleReport& report,
                      std::optional<Duration> max_cycle_time);

}  // namespace lec6::cli
