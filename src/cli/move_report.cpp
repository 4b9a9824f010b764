#include "cli/move_report.hpp"

#include <unistd.h>

#include <cmath>

#include "cli/views.hpp"
#include "lec6/client/errors.hpp"

namespace lec6::cli {
namespace {

nlohmann::json ms_or_null(const std::optional<Duration>& d) {
  if (!d) return nullptr;
  return std::round(to_ms(*d) * 10.0) / 10.0;
}

std::string_view operation_name(client::Operation o) {
  switch (o) {
    case client::Operation::Positioning:
      return "positioning";
    case client::Operation::Pushing:
      return "pushing";
    case client::Operation::Home:
      return "home";
    case client::Operation::Jog:
      return "jog";
  }
  return "?";
}

}  // namespace

int exit_code(const client::MoveResult& r) {
  using client::MoveOutcome;
  switch (r.outcome) {
    case MoveOutcome::Reached:
    case MoveOutcome::Pushed:
      return kSuccess;
    case MoveOutcome::Alarm:
      return kAlarm;
    case MoveOutcome::Deadline:
      return kDeadline;
    case MoveOutcome::Stopped:
      return r.stop_cause == client::StopCause::Interrupted ? kInterrupted : kFailure;
    case MoveOutcome::PushMissed:
    case MoveOutcome::NotStarted:
      return kFailure;
  }
  return kFailure;
}

nlohmann::json move_json(const client::MoveResult& r) {
  nlohmann::json j = state_json(r.state, r.flags, r.alarm_codes);
  j["outcome"] = std::string(client::outcome_name(r.outcome));
  j["message"] = r.describe();
  j["in_position"] = r.in_position;
  j["elapsed_s"] = to_seconds(r.elapsed);
  nlohmann::json goal{{"operation", std::string(operation_name(r.goal.operation))}};
  if (r.goal.step) goal["step"] = *r.goal.step;
  if (r.goal.operation != client::Operation::Jog) {
    goal["target_mm"] = mm_json(r.goal.target_001mm);
    if (r.goal.operation == client::Operation::Pushing) {
      goal["pushing_distance_mm"] = mm_json(r.goal.pushing_distance_001mm);
    } else {
      goal["in_position_mm"] = mm_json(r.goal.in_position_001mm);
    }
  }
  if (!r.goal.kept.empty()) goal["kept_from_controller"] = r.goal.kept;
  j["goal"] = goal;
  j["timeline"] = {{"start_ms", 0},
                   {"busy_up_ms", ms_or_null(r.timeline.busy_up)},
                   {"busy_down_ms", ms_or_null(r.timeline.busy_down)},
                   {"inp_ms", ms_or_null(r.timeline.inp)}};
  j["evidence"] = r.evidence;
  return j;
}

void report_move(const Session& s, const client::MoveResult& r) {
  if (!s.json() && isatty(fileno(stderr))) fmt::print(stderr, "\r\033[K");  // end the progress line
  if (s.json()) {
    print_json(move_json(r));
  } else if (r.succeeded()) {
    fmt::print("{}\n", r.describe());
  }
  if (!r.succeeded()) throw CommandFailed(exit_code(r), r.describe());
}

void with_move_report(const Session& s, const std::function<void()>& run) {
  try {
    run();
  } catch (const client::WithMoveResult& e) {
    if (!s.json() && isatty(fileno(stderr))) fmt::print(stderr, "\r\033[K");
    if (s.json() && e.move_result()) print_json(move_json(*e.move_result()));
    throw;
  }
}

}  // namespace lec6::cli
