#include "op_results.hpp"

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

}  // namespace

OpResult refusal(int status, const std::string& message, const std::string& field) {
  nlohmann::json body{{"ok", false}, {"error", message}};
  if (!field.empty()) body["field"] = field;
  return {status, body};
}

OpResult done_result(Op op, const std::string& message) {
  return {200, {{"ok", true}, {"op", op_name(op)}, {"message", message}}};
}

OpResult move_result(Op op, const client::MoveResult& r, bool stopped_by_other) {
  nlohmann::json body = state_part(r);
  body["op"] = op_name(op);
  if (r.in_position) {
    body["ok"] = true;
    body["outcome"] = "reached";
    body["message"] = fmt::format("{} at {} mm (INP = 1)", op == Op::Home ? "homed" : "reached",
                                  lec::format_mm(r.state.position_001mm));
    return {200, body};
  }
  body["ok"] = false;
  body["outcome"] = stopped_by_other ? "stopped" : "ended without INP";
  body["message"] =
      stopped_by_other
          ? fmt::format("stopped at {} mm before the target {} mm (stop, hold or reset)",
                        lec::format_mm(r.state.position_001mm),
                        lec::format_mm(r.state.target_001mm))
          : fmt::format(
                "BUSY fell at {} mm without INP: outside the in-position band (a push "
                "that missed, or a stop)",
                lec::format_mm(r.state.position_001mm));
  return {422, body};
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

OpResult reset_result(const std::vector<uint8_t>& still_active) {
  nlohmann::json body{{"ok", still_active.empty()}, {"op", "reset"}};
  body["alarms"] = alarms_json(still_active);
  body["message"] =
      still_active.empty()
          ? "RESET pulse: no alarm active"
          : fmt::format("RESET pulse: alarm {} is still active (not resettable by RESET)",
                        still_active.front());
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
  lec::StepData want = have;
  if (have.is_blank() && !fields.contains(lec::StepField::MovementMode)) {
    want.movement_mode = lec::MovementMode::Absolute;  // a new step is ABS unless told
  }
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
  nlohmann::json body{{"ok", report.ok()},
                      {"op", "step-write"},
                      {"message", report.summary()},
                      {"written", report.count(client::StepOutcome::Written) > 0}};
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
  } catch (const client::AlarmError& x) {
    auto r = refusal(422, x.what());
    r.body["outcome"] = "alarm";
    r.body["alarms"] = alarms_json(x.codes());
    return r;
  } catch (const client::DeadlineError& x) {
    auto r = refusal(504, x.what());
    r.body["outcome"] = "deadline";
    return r;
  } catch (const client::Cancelled& x) {
    auto r = refusal(stopped_by_other ? 422 : 503, x.what());
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
