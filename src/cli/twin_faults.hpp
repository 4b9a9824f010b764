#pragma once
// The faults of a cycle (`faults:`, --fault) acted out on the twin of
// `lec cycle run --port sim` (docs/cycles.md, "Faults"): at the step and run
// each names, a push_miss takes the axis's workpiece away before the step
// starts (and puts it back once the step has ended and the carriage is back
// on the side it pushed from, so that the next pass finds its part); an alarm
// is raised and a controller cut off the line once the step's starts were
// sent. Each fault strikes at most once. Attacked through `lec` by
// tests/integration/cycle_test.sh; the twin's side and the runner's moments
// by tests/cycle/faults_test.cpp.

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "cli/cycle_lines.hpp"
#include "cli/cycle_report.hpp"
#include "lec6/cycle/cycle.hpp"
#include "lec6/cycle/runner.hpp"

namespace lec6::cli {

class TwinFaults {
 public:
  // `cycle` (the one the Runner runs) and `lines` (simulated) must outlive this.
  TwinFaults(const cycle::Cycle& cycle, const std::vector<cycle::Fault>& faults, CycleLines& lines);

  // RunOptions::at_step. Never throws: what could not be done is in report().
  void at_step(const cycle::Step& step, const std::string& path, cycle::StepMoment moment);

  // Every fault, in the order of the file and the command line.
  std::vector<InjectedFault> report() const;
  // A fault's line for the live printout, as it strikes (empty: nothing new).
  std::vector<std::string> take_news();

 private:
  struct Armed {
    cycle::Fault fault;
    const cycle::Step* step = nullptr;  // resolved in the Cycle
    uint8_t id = 0;
    bool done = false;  // struck, or its run ended before it could
    // A push_miss's workpiece, away: put back (where it was) once its step
    // has ended and the carriage is back on the side it pushed from.
    std::optional<double> away_mm;
    bool pushed_from_above = false;
    bool step_ended = false;
    InjectedFault outcome;
  };
  void strike(Armed& a, const cycle::Step& step, const std::string& path);
  void put_back(Armed& a);
  sim::Controller* twin(const Armed& a);

  CycleLines& lines_;
  std::vector<Armed> armed_;
  std::map<const cycle::Step*, unsigned> runs_;
  std::vector<std::string> news_;
};

}  // namespace lec6::cli
