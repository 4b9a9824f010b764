// A stop judged by the axis (stop.hpp): the edge the controller needs, then
// reads until the axis is at rest, escalating when it is not.

#include <fmt/format.h>

#include <algorithm>

#include "lec6/client/actuator.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::client {
namespace {

using lec::Coil;

// Reads that fail in a row before the judgement gives up on a controller
// that does not answer (each already had its own attempts).
constexpr int kFailedReadsGiveUp = 2;

std::string joined(const std::vector<std::string>& actions) {
  std::string out;
  for (const auto& a : actions) out += (out.empty() ? "" : ", then ") + a;
  return out.empty() ? "nothing could be written" : out;
}

}  // namespace

std::string StopReport::describe() const {
  const char* what = kind == StopKind::Hold ? "hold" : "stop";
  if (stopped) {
    return fmt::format("{} at {} mm after {:.2f} s ({})",
                       kind == StopKind::Hold ? "held" : "stopped",
                       lec::format_mm(state.position_001mm), to_seconds(took), joined(actions));
  }
  if (!answered) {
    return fmt::format(
        "{} sent ({}); the axis could not be read afterwards{}: whether it stopped "
        "is not known",
        what, joined(actions), problem.empty() ? "" : " (" + problem + ")");
  }
  return fmt::format("{} sent ({}); the axis is still moving at {} mm/s at {} mm{}", what,
                     joined(actions), state.speed_mm_s, lec::format_mm(state.position_001mm),
                     problem.empty() ? "" : " (" + problem + ")");
}

// One look at the axis: flags and state. At rest: speed 0, and for a stop
// BUSY 0 too (a held operation keeps BUSY).
bool Actuator::at_rest(StopKind kind, StopReport& report) {
  report.flags = client_.read_flags();
  report.state = client_.read_state();
  report.answered = true;
  return report.state.speed_mm_s == 0 && (kind == StopKind::Hold || !report.flags.busy());
}

bool Actuator::watch(StopKind kind, const StopPolicy& policy, TimePoint until_rest,
                     TimePoint deadline, StopReport& report) {
  const Clock& clock = client_.clock();
  const TimePoint began = clock.now();
  bool budget_set = false;
  int failed = 0;
  int looks = 0;
  for (;;) {
    try {
      if (at_rest(kind, report)) return true;
      failed = 0;
      if (!budget_set) {
        // The time the speed now read needs at the deceleration, plus the margin.
        const unsigned decel = policy.decel_mm_s2 ? policy.decel_mm_s2 : policy.assumed_decel_mm_s2;
        const auto needs = std::chrono::duration_cast<Duration>(std::chrono::duration<double>(
            static_cast<double>(report.state.speed_mm_s) / std::max(1U, decel)));
        until_rest = std::max(until_rest, began + needs + policy.margin);
        budget_set = true;
      }
    } catch (const TransportError& e) {
      report.problem = e.what();
      if (++failed >= kFailedReadsGiveUp) return false;
    }
    const TimePoint now = clock.now();
    ++looks;
    // Two looks at least: one slow read must not escalate a stop that worked.
    if ((now >= until_rest && looks >= 2) || now >= deadline) return false;
  }
}

StopReport Actuator::stop(StopKind kind, const StopPolicy& policy) {
  StopReport report;
  report.kind = kind;
  const Clock& clock = client_.clock();
  const TimePoint began = clock.now();
  const TimePoint deadline = began + policy.deadline;
  const auto attempt = [&](auto&& write) {
    try {
      write();
      return true;
    } catch (const TransportError& e) {
      report.problem = e.what();
      return false;
    }
  };
  // 1. The edge, written before anything is read: a read first would wait
  // behind other clients' requests on a shared line.
  if (kind == StopKind::Hold) {
    // Never HOLD <- 0: it would resume a held operation. A HOLD already at
    // 1 stays; if the axis moves all the same, the judgement says so.
    if (attempt([&] { client_.write_coil(Coil::HOLD, true); }))
      report.actions.push_back("HOLD <- 1");
  } else {
    const bool sent = attempt([&] { client_.write_coil(Coil::RESET, true); });
    // Released whatever happened: a 1 heard with its reply lost would spoil the next edge.
    attempt([&] { client_.write_coil(Coil::RESET, false); });
    if (sent) report.actions.push_back("RESET pulse");
  }
  // 2. The axis says whether it stopped.
  bool rest = watch(kind, policy, began + policy.margin, deadline, report);
  // 2b. Still moving after the pulse: RESET may have been at 1 before it
  // (another client's maintained button: a 1 over a 1 is no edge). Our
  // pulse left it at 0, so a second one is an edge.
  if (!rest && report.answered && kind == StopKind::Stop && clock.now() < deadline) {
    const bool sent = attempt([&] { client_.write_coil(Coil::RESET, true); });
    attempt([&] { client_.write_coil(Coil::RESET, false); });
    if (sent) report.actions.push_back("RESET pulse again (RESET may have been left at 1)");
    rest = watch(kind, policy, clock.now() + policy.margin, deadline, report);
  }
  // 3. Escalation, by the policy.
  if (!rest && report.answered && kind == StopKind::Stop && policy.escalate_hold &&
      clock.now() < deadline) {
    if (attempt([&] { client_.write_coil(Coil::HOLD, true); }))
      report.actions.push_back("HOLD <- 1 (left on: `lec hold off` releases it)");
    rest = watch(StopKind::Hold, policy, clock.now() + policy.margin, deadline, report);
  }
  if (!rest && report.answered && policy.escalate_servo_off && clock.now() < deadline) {
    if (attempt([&] { client_.write_coil(Coil::SVON, false); }))
      report.actions.push_back("SVON <- 0 (servo off)");
    rest = watch(StopKind::Hold, policy, clock.now() + policy.margin, deadline, report);
  }
  report.stopped = rest;
  report.took = clock.now() - began;
  return report;
}

}  // namespace lec6::client
