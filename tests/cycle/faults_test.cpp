// Faults for the twin (`faults:`, --fault; docs/cycles.md "Faults"): the
// file's rules (each refused with file, line, column, field), and on the
// twin, through the runner's step moments, what each fault does to a cycle:
// a push that misses takes its branch, an alarm aborts and stops every axis,
// a controller cut off the line ends the cycle as a line fault, saying that
// axis was not seen at rest.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "cell_fixture.hpp"
#include "lec6/cycle/analysis.hpp"
#include "lec6/cycle/cycle_file.hpp"

namespace lec6::cycle {
namespace {

using testing::Cell;
using ::testing::HasSubstr;
using ::testing::Not;
using namespace std::chrono_literals;

const std::string kFaultCell = R"(cycle: press
repeat: 2
axes:
  x: {id: 1, soft_limits: [0, 400]}
  z: {id: 2, twin: {workpiece_mm: 85}}
steps:
  - parallel:
      - move: {axis: x, to: 200, speed: 200}
      - move: {axis: z, to: 10}
  - push: {axis: z, to: 80, force: 40, distance: 10, on_miss: reject}
  - repeat:
      times: 3
      steps:
        - move: {axis: x, to: 10, relative: true}
        - dwell: 50ms
  - move: {axis: z, to: 10}
branches:
  reject:
    - move: {axis: z, to: 0}
)";

std::string fault_refused(const std::string& faults) {
  try {
    parse_cycle(kFaultCell + faults, "cell.yaml");
  } catch (const CycleError& e) {
    return e.what();
  }
  return "accepted";
}

TEST(CycleFaults, TheFileNamesAStepAnAxisAndARunThatComes) {
  const Cycle c = parse_cycle(kFaultCell + R"(faults:
  - {step: 2, push_miss: z, pass: 2}
  - {step: 3.2, alarm: x, code: 62}
  - {step: reject.1, cut_off: z}
)",
                              "cell.yaml");
  ASSERT_EQ(c.faults.size(), 3u);
  EXPECT_EQ(c.faults[0].kind, Fault::Kind::PushMiss);
  EXPECT_EQ(c.faults[0].pass, 2u);
  EXPECT_EQ(c.faults[0].text, "z's push at step 2 finds no workpiece (its 2nd run)");
  EXPECT_EQ(c.faults[1].alarm_code, 62);
  EXPECT_EQ(c.faults[1].text, "alarm 62 on x at step 3.2");
  EXPECT_EQ(c.faults[2].text, "z cut off the line at step reject.1");
  EXPECT_EQ(find_step(c, "3.2")->text, c.steps[2].steps[1].text);
  EXPECT_EQ(find_step(c, "3.4"), nullptr);
  EXPECT_EQ(find_step(c, "reject"), nullptr);

  EXPECT_THAT(fault_refused("faults:\n  - {step: 2, push_miss: y}\n"),
              HasSubstr("cell.yaml:21:26: faults[0].push_miss: unknown axis 'y' (axes: x, z)"));
  EXPECT_THAT(fault_refused("faults:\n  - {step: 9, alarm: x}\n"),
              HasSubstr("faults[0].step: no step '9' in this cycle (steps 1-4, branches"));
  EXPECT_THAT(fault_refused("faults:\n  - {step: 3, alarm: x}\n"),
              HasSubstr("faults[0].step: step 3 is a repeat: name one of its steps (3.1 to 3.2)"));
  EXPECT_THAT(fault_refused("faults:\n  - {step: 1, push_miss: z}\n"),
              HasSubstr("faults[0].push_miss: step 1 (parallel"));
  EXPECT_THAT(fault_refused("faults:\n  - {step: 1, push_miss: z}\n"),
              HasSubstr("has no push of z"));
  // Step 3.1 runs 3 times per pass, 2 passes: a 7th run never comes.
  EXPECT_THAT(fault_refused("faults:\n  - {step: 3.1, alarm: x, pass: 7}\n"),
              HasSubstr("step 3.1 runs 6 times in a run of this cycle: pass 7 never comes"));
  EXPECT_EQ(fault_refused("faults:\n  - {step: 3.1, alarm: x, pass: 6}\n"), "accepted");
  EXPECT_THAT(fault_refused("faults:\n  - {step: 2, cut_off: z, code: 3}\n"),
              HasSubstr("faults[0].code: only an alarm has a code"));
  EXPECT_THAT(fault_refused("faults:\n  - {step: 2, alarm: z, cut_off: z}\n"),
              HasSubstr("give exactly one of push_miss: AXIS, alarm: AXIS or cut_off: AXIS"));
  EXPECT_THAT(fault_refused("faults:\n  - {step: 2, alarm: z, code: 300}\n"),
              HasSubstr("faults[0].code"));
  EXPECT_THAT(fault_refused("faults:\n  - {step: 2, alarm: z, when: 3}\n"),
              HasSubstr("faults[0].when: unknown key 'when'"));

  EXPECT_EQ(find_step(c, "02"), find_step(c, "2"));  // a number, however written
  try {  // a stored step runs to its end before an alarm's moment comes
    parse_cycle(R"(axes: {x: 1}
steps:
  - run_step: {axis: x, step: 1}
faults:
  - {step: 1, alarm: x}
)",
                "cell.yaml");
    ADD_FAILURE() << "an alarm on a run_step accepted";
  } catch (const CycleError& e) {
    EXPECT_THAT(e.what(), HasSubstr("faults[0].step: step 1 runs a stored step"));
  }
  // Branch names that would make a step's path ambiguous.
  for (const char* name : {"a.b", "2"}) {
    try {
      parse_cycle(std::string(kFaultCell)
                      .replace(kFaultCell.find("  reject:"), 9, std::string("  ") + name + ":"),
                  "cell.yaml");
      ADD_FAILURE() << name << " accepted";
    } catch (const CycleError& e) {
      EXPECT_THAT(e.what(), HasSubstr("a branch name has no '.' and is not a number")) << name;
    }
  }

  // --fault: the same rules, the same reader.
  const Cycle plain = parse_cycle(kFaultCell, "cell.yaml");
  EXPECT_EQ(parse_fault("{step: 2, push_miss: z}", "--fault", plain).kind, Fault::Kind::PushMiss);
  try {
    parse_fault("{step: 2, push_miss: q}", "--fault", plain);
    ADD_FAILURE() << "accepted";
  } catch (const CycleError& e) {
    EXPECT_THAT(e.what(), HasSubstr("--fault:1:22: fault.push_miss: unknown axis 'q'"));
  }
}

// The faults acted out on the twin as lec cycle run does (cli/cycle_faults.cpp)
// at the runner's step moments.
struct Injector {
  Injector(const Cycle& c, const std::string& path, unsigned p = 1)
      : step(find_step(c, path)), pass(p) {}
  const Step* step;
  unsigned pass = 1;
  std::function<void()> before, started;
  unsigned runs = 0;
  void operator()(const Step& s, const std::string&, StepMoment m) {
    if (&s != step) return;
    if (m == StepMoment::Before) ++runs;
    if (runs != pass) return;
    if (m == StepMoment::Before && before) before();
    if (m == StepMoment::Started && started) started();
  }
};

TEST(CycleFaults, APushThatMissesTakesItsBranchOnlyOnItsRun) {
  Cell cell(kFaultCell);
  Injector inject(cell.cycle, "2", 2);
  sim::Controller& z = *cell.bus.find(2);
  inject.before = [&] { z.set_workpiece(std::nullopt, cell.clock.now()); };
  RunOptions o;
  o.at_step = std::ref(inject);
  const CycleReport r = cell.run(o);
  ASSERT_TRUE(r.completed) << r.ended;
  std::vector<std::string> pushes;
  for (const auto& s : r.steps) {
    if (s.path.rfind("2 ", 0) == 0)
      pushes.push_back(std::string(outcome_name(s.axes.at(0).outcome)));
  }
  EXPECT_EQ(pushes, (std::vector<std::string>{"pushed", "push_missed"}));
  EXPECT_EQ(std::count_if(r.steps.begin(), r.steps.end(),
                          [](const StepReport& s) { return s.path.rfind("reject.", 0) == 0; }),
            1);
}

TEST(CycleFaults, AnAlarmOnceTheStepStartedAbortsAndStopsEveryAxis) {
  Cell cell(kFaultCell);
  Injector inject(cell.cycle, "1");
  inject.started = [&] { cell.bus.find(1)->inject_alarm(149, cell.clock.now()); };
  RunOptions o;
  o.at_step = std::ref(inject);
  const CycleReport r = cell.run(o);
  EXPECT_FALSE(r.completed);
  EXPECT_THAT(r.ended, HasSubstr("aborted at step 1 (1/2)"));
  EXPECT_THAT(r.ended, HasSubstr("alarm"));
  // The alarm's code and meaning, read after the flags showed it (not "no
  // code in the history").
  ASSERT_FALSE(r.steps.empty());
  ASSERT_FALSE(r.steps.back().axes.empty());
  EXPECT_THAT(r.steps.back().axes[0].detail, HasSubstr("alarm 149: "));
  EXPECT_THAT(r.steps.back().axes[0].detail, Not(HasSubstr("no code in the history")));
  // z, cut short, ended when the abort came: the stops after it are the
  // step's ("after", the line's), not z's motion.
  const StepReport& s = r.steps.back();
  ASSERT_EQ(s.axes.size(), 2u);
  EXPECT_EQ(s.axes[1].outcome, Outcome::Stopped);
  EXPECT_LT(s.axes[1].end, s.end - 50ms);
  const CycleAnalysis a = analyse(r);
  const bool after =
      std::any_of(a.critical_path.begin(), a.critical_path.end(),
                  [](const Segment& g) { return g.share == Share::After && g.to - g.from > 50ms; });
  EXPECT_TRUE(after) << "the stops of the abort are not the line's";
}

TEST(CycleFaults, AControllerCutOffTheLineEndsTheCycleAndIsNotSeenAtRest) {
  Cell cell(kFaultCell);
  Injector inject(cell.cycle, "1");
  inject.started = [&] { cell.bus.set_cut_off(1, true); };
  RunOptions o;
  o.at_step = std::ref(inject);
  const CycleReport r = cell.run(o);
  EXPECT_FALSE(r.completed);
  EXPECT_THAT(r.ended, HasSubstr("line fault during step 1"));
  ASSERT_EQ(r.stood.size(), 2u);
  EXPECT_EQ(r.stood[0].axis, "x");
  EXPECT_FALSE(r.stood[0].stopped) << r.stood[0].how;  // never "at rest" unseen
  EXPECT_TRUE(r.stood[1].stopped) << r.stood[1].how;   // z still answers and stopped
  EXPECT_FALSE(r.stood[0].answered);
  // The step that met the line fault keeps its members.
  ASSERT_EQ(r.steps.back().axes.size(), 2u);
  EXPECT_EQ(r.steps.back().axes[0].outcome, Outcome::LineFault);
  EXPECT_EQ(outcome_name(Outcome::LineFault), "line_fault");
  EXPECT_FALSE(outcome_from_name("line_fault"));  // no `on:` can name it
  // Cut off, x heard no stop: the twin's axis went on to its target.
  cell.bus.set_cut_off(1, false);
  cell.clock.advance(3s);
  EXPECT_EQ(cell.position_001mm("x"), 20000);
}

}  // namespace
}  // namespace lec6::cycle
