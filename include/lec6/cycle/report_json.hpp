#pragma once
// A cycle's report as JSON: what `lec cycle run --json` prints and what
// `POST /api/cycles/{name}/run` of lec serve answers with (docs/cycles.md).
//
// Thread safety: pure functions.

#include <string>
#include <vector>

#include "lec6/cycle/analysis.hpp"
#include "lec6/cycle/runner.hpp"

namespace lec6::cycle {

// What a fault of the file or --fault did on the twin (the CLI's TwinFaults).
struct InjectedFault {
  std::string fault;  // Fault::text
  std::string step;   // the step's path as reported ("6 (2/2)"); empty: it never came
  bool injected = false;
  std::string what;  // "injected", or why not
};

// The report with its analysis, indented. `simulated`: the twin's simulated
// time; `faults`: what each fault did (--port sim).
std::string report_json(const std::string& cycle_name, const CycleReport& report,
                        const CycleAnalysis& analysis, bool simulated,
                        const std::vector<InjectedFault>& faults = {});

}  // namespace lec6::cycle
