#pragma once
// `lec cycle run --report FILE.html`: a standalone page (no script, no
// network) with the cycle's Gantt chart as SVG (a lane per axis, the
// critical path outlined, the line's share in a lane of its own), the
// time split into motion, line and program, each axis's and each line's
// utilisation, the steps as a table and, after a stop or an abort, where
// each axis stood. Attacked by tests/integration/cycle_test.sh and the
// browser test web/test/cycle_report.test.mjs (a screenshot).

#include <string>

#include "lec6/cycle/analysis.hpp"
#include "lec6/cycle/runner.hpp"

namespace lec6::cli {

struct CycleReportPage {
  std::string cycle;  // the cycle's name
  std::string file;   // the cycle file
  std::string where;  // CycleLines::describe()
  bool simulated = false;
};

std::string cycle_html(const CycleReportPage& page, const cycle::CycleReport& report,
                       const cycle::CycleAnalysis& analysis);

}  // namespace lec6::cli
