#include "ops/op_results.hpp"
#include "lec6/client/action_words.hpp"

#include <fmt/format.h>

#include "lec6/client/errors.hpp"
#include "lec6/client/step_sync.hpp"
#include "lec6/lec/alarms.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::serve {
namespace {

double mm(int64_t v001) {
  return static_cast<double>(v001) / 100.0;
}

nlohmann::json state_part(const client::MoveResult& r) {
  return {{"position_mm", mm(r.state.position_001mm)},
          {"target_mm", mm(r.state.target_001mm)},
          {"speed_mm_s", r.state.speed_mm_s},
          {"thrust_pct", r.state.thrust_pct},
          {"inp", r.flags.inp()},
          {"busy", r.flags.busy()},
          {"elapsed_s", to_seconds(r.elapsed)}};
}

nlohmann::json alarms_json(const std::vector<uint8_t>& codes) {
  auto out = nlohmann::json::array();
  for (uint8_t c : codes) {
    out.push_back({{"code", c}, {"meaning", std::string(lec::alarm_meaning(c))}});
  }
  return out;
}

nlohmann::json seconds_or_null(const std::optional<Duration>& d) {
  return d ? nlohmann::json(to_seconds(*d)) : nlohmann::json(nullptr);
}

// outcome, message, evidence and the flag timeline of a move.
void add_move_details(nlohmann::json& body, const client::MoveResult& r) {
  body["outcome"] = std::string(client::outcome_name(r.outcome));
  body["message"] = client::in_terms_of(r.describe(), client::Interface::Http);
  body["evidence"] = r.evidence;
  if (!r.goal.kept.empty()) body["kept_from_controller"] = r.goal.kept;
  if (r.goal.operation == client::Operation::Positioning && r.goal.speed_mm_s > 0 &&
      r.goal.from_001mm) {
    // issue 32: the history times the motion against the profile it was given
    body["profile"] = {{"from_mm", mm(*r.goal.from_001mm)},
                       {"speed_mm_s", r.goal.speed_mm_s},
                       {"acceleration_mm_s2", r.goal.acceleration_mm_s2},
                       {"deceleration_mm_s2", r.goal.deceleration_mm_s2}};
  }
  body["timeline"] = {{"busy_up_s", seconds_or_null(r.timeline.busy_up)},
                      {"busy_down_s", seconds_or_null(r.timeline.busy_down)},
                      {"inp_s", seconds_or_null(r.timeline.inp)},
                      // issue 32: each BUSY edge lies between *_after_s and its time
                      {"busy_up_after_s", seconds_or_null(r.timeline.busy_up_after)},
                      {"busy_down_after_s", seconds_or_null(r.timeline.busy_down_after)},
                      {"inp_after_s", seconds_or_null(r.timeline.inp_after)},
                      // the line clock's time they count from (the history's samples
                      // are on the same clock)
                      {"origin_ns", std::chrono::duration_cast<std::chrono::nanoseconds>(
                                        r.timeline.origin.time_since_epoch())
                                        .count()}};
}

// An error that ended a move: its state and timeline with the refusal.
void add_move_of(nlohmann::json& body, const client::WithMoveResult& e) {
  if (!e.move_result()) return;
  const std::string error = body.value("error", "");
  body.update(state_part(*e.move_result()));
  add_move_details(body, *e.move_result());
  if (!error.empty()) body["message"] = error;
}

}  // namespace

OpResult refusal(int status, const std::string& message, const std::string& field) {
  // The library's advice names `lec` commands: HTTP and MQTT clients get the
  // request that does the same (client/action_words.hpp).
  nlohmann::json body{{"ok", false},
                      {"error", client::in_terms_of(message, client::Interface::Http)}};
  if (!field.empty()) body["field"] = field;
  return {status, body};
}

OpResult done_result(Op op, const std::string& message) {
  return {200, {{"ok", true}, {"op", op_name(op)}, {"message", message}}};
}

// The move's one line and outcome are the Actuator's (client/move_result.hpp),
// so `lec move`, the Python module and the API say the same thing.
OpResult move_result(Op op, const client::MoveResult& r, bool stopped_by_other) {
  nlohmann::json body = state_part(r);
  body["op"] = op_name(op);
  add_move_details(body, r);
  body["ok"] = r.succeeded();
  if (r.outcome == client::MoveOutcome::Stopped && r.stop_cause == client::StopCause::Unknown &&
      stopped_by_other) {
    // Here we know who: a stop, hold or reset went through this daemon.
    body["message"] = fmt::format(
        "stopped at {} mm before the target {} mm: a stop, hold or reset sent through lec serve",
        lec::format_mm(r.state.position_001mm), lec::format_mm(r.goal.target_001mm));
  }
  return {r.succeeded() ? 200 : 422, body};
}

OpResult jog_result(const client::MoveResult& r, bool lease_expired, bool stream_closed) {
  nlohmann::json body = state_part(r);
  body["ok"] = true;
  body["op"] = "jog";
  body["outcome"] = "stopped";
  body["message"] =
      fmt::format("jog released at {} mm{}", lec::format_mm(r.state.position_001mm),
                  stream_closed   ? " (the dashboard's connection closed: released by lec serve)"
                  : lease_expired ? " (its lease was not renewed: released by lec serve)"
                                  : "");
  return {200, body};
}

OpResult reset_result(const std::vector<uint8_t>& still_active, lec::AlarmPolarity polarity) {
  nlohmann::json body{{"ok", still_active.empty()}, {"op", "reset"}};
  body["alarms"] = alarms_json(still_active);
  body["message"] = still_active.empty()
                        ? "RESET pulse: no alarm active"
                        : "RESET pulse: " + lec::alarm_after_reset(still_active, polarity);
  return {still_active.empty() ? 200 : 422, body};
}

nlohmann::json step_json(const lec::StepData& data) {
  lec::StepTable t;
  t.covered.reset();
  t.covered.set(0);
  t.steps[0] = data;
  auto j = nlohmann::json::parse(lec::to_json(t));
  auto step = j["steps"][0];
  step.erase("step");
  return step;
}

OpResult step_read_result(unsigned step, const lec::StepData& data) {
  nlohmann::json body = step_json(data);
  body["step"] = step;
  return {200, {{"ok", true}, {"op", "step-read"}, {"step", body}}};
}

OpResult table_result(const lec::StepTable& table) {
  return {
      200,
      {{"ok", true}, {"op", "step-read"}, {"table", nlohmann::json::parse(lec::to_json(table))}}};
}

OpResult step_write(client::Client& c, unsigned step,
                    const std::map<lec::StepField, int64_t>& fields) {
  const lec::StepData have = c.read_step(step);
  // A blank step starts from the gentle defaults of a direct move (ABS,
  // 100 mm/s, 1000 mm/s², docs/api.md), so setting a position is enough.
  lec::StepData want = have.is_blank() ? client::default_direct_data() : have;
  for (const auto& [f, raw] : fields) lec::set_field(want, f, raw);
  const auto issues = lec::validate(want);
  if (!issues.empty()) {
    const auto& info = lec::field_info(issues.front().field);
    return refusal(400, fmt::format("step {}: {}", step, issues.front().message),
                   std::string(info.csv_column));
  }
  const auto plan = client::plan_step(step, have, want);
  const auto report = client::apply_restore(c, plan);
  if (!report.ok() && report.exception) std::rethrow_exception(report.exception);
  const bool written = report.count(client::StepOutcome::Written) > 0;
  nlohmann::json body{{"ok", report.ok()},
                      {"op", "step-write"},
                      {"message", report.ok() ? fmt::format("step {} {}", step,
                                                            written ? "written and read back"
                                                                    : "unchanged: nothing written")
                                              : report.summary()},
                      {"written", written}};
  nlohmann::json s = step_json(want);
  s["step"] = step;
  body["step"] = s;
  if (!report.ok()) body["error"] = report.steps.empty() ? "failed" : report.steps.front().error;
  return {report.ok() ? 200 : 502, body};
}

OpResult result_of(std::exception_ptr e, bool stopped_by_other) {
  try {
    std::rethrow_exception(e);
  } catch (const client::InvalidRequest& x) {
    return refusal(409, x.what());
  } catch (const client::ControllerException& x) {
    auto r = refusal(422, x.what());
    r.body["exception_code"] = static_cast<int>(x.code());
    return r;
  } catch (const client::MoveNotStarted& x) {
    auto r = refusal(502, x.what());
    add_move_of(r.body, x);
    r.body["outcome"] = "not_started";
    return r;
  } catch (const client::AlarmError& x) {
    auto r = refusal(422, x.what());
    add_move_of(r.body, x);
    r.body["outcome"] = "alarm";
    r.body["alarms"] = alarms_json(x.codes());
    return r;
  } catch (const client::DeadlineError& x) {
    auto r = refusal(504, x.what());
    add_move_of(r.body, x);
    r.body["outcome"] = "deadline";
    return r;
  } catch (const client::Superseded& x) {
    // A stop from anywhere (a PLC's HOLD too) came before its start.
    auto r = refusal(422, x.what());
    add_move_of(r.body, x);
    r.body["outcome"] = "stopped";
    return r;
  } catch (const client::Cancelled& x) {
    auto r = refusal(stopped_by_other ? 422 : 503, x.what());
    add_move_of(r.body, x);
    r.body["outcome"] = "stopped";
    return r;
  } catch (const client::TransportError& x) {
    const bool down = x.kind() == client::TransportErrorKind::Port;
    auto r = refusal(down ? 503 : 502, x.what());
    r.body["transport"] = std::string(client::transport_error_name(x.kind()));
    return r;
  } catch (const std::exception& x) {
    return refusal(500, x.what());
  }
}

}  // namespace lec6::serve
