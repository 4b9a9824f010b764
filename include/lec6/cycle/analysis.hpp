#pragma once
// Where a cycle's time went, from its report alone (sans-I/O): the critical
// path, each step's time split into the line's share and the axes', each
// axis's and each line's utilisation, and a parallel group's start skew.
//
//   const cycle::CycleAnalysis a = cycle::analyse(report);
//
// A step ends when its last member does, so the critical path runs through
// each step's member that ended last (the first of them on a tie). Along it
// the cycle time splits into segments that tile it exactly, from 0 to the
// cycle time:
//   reads   the previous step's end -> this step's start: every axis read
//           before the step (the interlocks; the flags only before a dwell)
//   start   -> the critical member's start acknowledged: its checks and
//           direct data, and the group's starts sent before it
//   motion  -> the last poll that saw its BUSY high: the axis moving (a
//           lower bound: BUSY fell after it)
//   seen    -> the member's end: where BUSY fell, INP settled and the poll
//           that saw it (at most one poll round of it is the line's)
//   dwell   a dwell's time;  wait  a wait's time for its condition
//   after   the member's end -> the step's end (the stops of an abort)
//   tail    the last step's end -> the cycle's end
// reads, start, seen, after and tail are the line's share; motion the axes';
// dwell and wait the program's. Attacked by tests/cycle/analysis_test.cpp
// (properties over random reports; a cycle on the twin).

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "lec6/cycle/runner.hpp"

namespace lec6::cycle {

enum class Share { Reads, Start, Motion, Seen, Dwell, Wait, After, Tail };
// "reads", "start", "motion", "seen", "dwell", "wait", "after", "tail"
std::string_view share_name(Share s) noexcept;
// reads, start, seen, after, tail: time the cycle spent on the line.
bool line_share(Share s) noexcept;

// One piece of the critical path.
struct Segment {
  std::string step;  // the step's path; empty for the tail
  std::string axis;  // the critical member's axis; empty for reads, a dwell, the tail
  Share share = Share::Motion;
  Duration from{};
  Duration to{};
};

struct StepShare {
  std::string step;
  std::string text;
  std::string critical_axis;                   // the member that ended last ("" for a dwell)
  std::optional<std::size_t> critical_member;  // its index in StepReport::axes
  Duration start{};
  Duration end{};
  Duration line{};     // its reads, start, seen and after
  Duration motion{};   // the critical member's motion
  Duration program{};  // a dwell or a wait
  // A group of several motions: the last one's start acknowledged minus the
  // first one's. Unset for one motion.
  std::optional<Duration> start_skew;
};

struct AxisUse {
  std::string axis;
  unsigned motions = 0;
  Duration moving{};       // the union of its motions, start acknowledged -> end seen
  double utilisation = 0;  // moving / cycle time
};

struct LineLoad {
  std::string line;
  std::vector<std::string> axes;
  uint64_t transactions = 0;
  uint64_t timeouts = 0;
  std::optional<double> utilisation;  // busy / cycle time; unset when not known
};

struct CycleAnalysis {
  Duration cycle_time{};
  std::vector<Segment> critical_path;
  Duration line{};  // line + motion + program == cycle_time
  Duration motion{};
  Duration program{};
  std::vector<StepShare> steps;
  std::vector<AxisUse> axes;
  std::vector<LineLoad> lines;
  std::optional<Duration> max_start_skew;  // over the groups of several motions
};

CycleAnalysis analyse(const CycleReport& report);

}  // namespace lec6::cycle
