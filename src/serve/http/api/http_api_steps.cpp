// The step table and twin endpoints of the HTTP API (http_api.hpp).

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <optional>

#include <nlohmann/json.hpp>

#include "history/history.hpp"  // issue 26
#include "http/api/http_api.hpp"
#include "lec6/client/step_sync.hpp"
#include "lec6/lec/step_table.hpp"
#include "lec6/sim/bus.hpp"
#include "ops/op_results.hpp"

namespace lec6::serve {
namespace {

using nlohmann::json;

std::optional<unsigned> step_number(std::string_view text) {
  unsigned n = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), n);
  if (ec != std::errc() || end != text.data() + text.size() || n > 63) return std::nullopt;
  return n;
}

lec::TableFormat format_of(const HttpRequest& req) {
  if (const auto f = req.query.find("format"); f != req.query.end()) {
    return f->second == "csv" ? lec::TableFormat::Csv : lec::TableFormat::Json;
  }
  const auto type = req.header("Content-Type").value_or("");
  return type.find("csv") != std::string_view::npos ? lec::TableFormat::Csv
                                                    : lec::TableFormat::Json;
}

json plan_json(const client::RestorePlan& plan) {
  json steps = json::array();
  for (const auto& change : plan.steps) {
    if (change.equal()) continue;
    json fields = json::array();
    for (lec::StepField f : change.fields) {
      const auto& info = lec::field_info(f);
      fields.push_back({{"field", info.csv_column},
                        {"label", info.label},
                        {"controller", lec::format_field(f, lec::get_field(change.have, f))},
                        {"file", lec::format_field(f, lec::get_field(change.want, f))}});
    }
    steps.push_back({{"step", change.step}, {"blanks", change.blanks()}, {"fields", fields}});
  }
  return {{"ok", true},
          {"to_write", plan.to_write()},
          {"unchanged", plan.unchanged()},
          {"steps", steps},
          {"notes", plan.notes}};
}

json report_json(const client::RestoreReport& report) {
  json steps = json::array();
  for (const auto& s : report.steps) {
    if (s.outcome == client::StepOutcome::Unchanged) continue;
    json one{{"step", s.change.step}, {"outcome", client::outcome_name(s.outcome)}};
    if (!s.error.empty()) one["error"] = s.error;
    steps.push_back(one);
  }
  return {{"ok", report.ok()},
          {"summary", report.summary()},
          {"written", report.count(client::StepOutcome::Written)},
          {"unchanged", report.count(client::StepOutcome::Unchanged)},
          {"failed", report.count(client::StepOutcome::Failed)},
          {"dry_run", report.dry_run},
          {"steps", steps},
          {"notes", report.notes}};
}

}  // namespace

void HttpApi::steps(const AxisRef& axis, std::vector<std::string_view> rest, HttpRequest& request,
                    Responder& responder) {
  auto res = responder;
  const bool get = request.method == "GET" || request.method == "HEAD";
  if (rest.empty() && get) {
    const bool csv = request.query.count("format") && request.query.at("format") == "csv";
    const std::string name = axis.name;
    return ops_.run_task(
        axis, "step-read", source(request),
        [](client::Client& c) { return table_result(client::backup_steps(c)); },
        [res, csv, name](OpResult r) {
          if (r.status != 200 || !csv) return void(res.respond(json_response(r.status, r.body)));
          auto t = lec::parse_json(r.body["table"].dump());
          auto out = text_response(200, lec::to_csv(*t), "text/csv; charset=utf-8");
          out.headers.set("Content-Disposition",
                          fmt::format("attachment; filename=\"{}-steps.csv\"", name));
          res.respond(out);
        });
  }
  if (rest.size() == 1 && rest[0] == "plan" && request.method == "POST") {
    auto table = lec::parse_table(request.body, format_of(request));
    if (!table) {
      auto r = error_response(400, table.error().empty() ? "empty file" : table.error().front());
      return void(res.respond(json_response(
          400, {{"ok", false}, {"error", table.error().front()}, {"errors", table.error()}})));
    }
    return ops_.run_task(
        axis, "step-plan", source(request),
        [t = *table](client::Client& c) {
          return OpResult{200, plan_json(client::plan_restore(c, t))};
        },
        [res](OpResult r) { res.respond(json_response(r.status, r.body)); });
  }
  if (rest.empty() && request.method == "POST") {
    auto table = lec::parse_table(request.body, format_of(request));
    if (!table) {
      return void(res.respond(json_response(400, {{"ok", false},
                                                  {"error", table.error().front()},
                                                  {"errors", table.error()},
                                                  {"written", 0}})));
    }
    client::ApplyOptions options;
    options.dry_run = request.query.count("dry_run") && request.query.at("dry_run") != "0";
    return ops_.run_task(
        axis, "step-restore", source(request),
        [t = *table, options](client::Client& c) {
          const auto report = client::apply_restore(c, client::plan_restore(c, t), options);
          return OpResult{report.ok() ? 200 : 502, report_json(report)};
        },
        [res, h = daemon_.history(), name = axis.name, dry = options.dry_run](OpResult r) {
          // issue 26: a restored table starts new drift baselines for its steps.
          if (h && !dry) h->on_step_table_edit(name, std::nullopt);
          res.respond(json_response(r.status, r.body));
        });
  }
  if (rest.size() == 1) {
    const auto n = step_number(rest[0]);
    if (!n) {
      return void(res.respond(error_response(400, "steps are numbered 0 to 63", "step")));
    }
    Command cmd;
    if (get) {
      cmd.op = Op::StepRead;
      cmd.step = *n;
    } else if (request.method == "PUT") {
      json args;
      try {
        args = request.body.empty() ? json::object() : json::parse(request.body);
      } catch (const json::exception& e) {
        return void(res.respond(
            error_response(400, fmt::format("the body is not valid JSON: {}", e.what()))));
      }
      if (!args.is_object())
        return void(res.respond(error_response(400, "expected a JSON object of fields")));
      args["step"] = *n;
      auto parsed = parse_command("step-write", args);
      if (!parsed) {
        return void(res.respond(error_response(400, parsed.error().message, parsed.error().field)));
      }
      cmd = std::move(*parsed);
    } else {
      auto r = error_response(405, "method not allowed here (allowed: GET, PUT)");
      r.headers.set("Allow", "GET, PUT");
      return void(res.respond(r));
    }
    return ops_.run(axis, std::move(cmd), source(request),
                    [res](OpResult r) { res.respond(json_response(r.status, r.body)); });
  }
  res.respond(error_response(404, fmt::format("no such endpoint: {}", request.path)));
}

namespace {

// The twin's workpiece (every controller on the line gets the same one, as
// the dashboard sets it); null: none.
json workpiece_of(sim::Bus& bus) {
  const auto ids = bus.ids();
  if (ids.empty()) return nullptr;
  const auto& w = bus.find(ids.front())->config().workpiece_mm;
  return w ? json(*w) : json(nullptr);
}

// Places the workpiece for every controller, or none: all are checked to be
// at rest first, so a refusal changes nothing. The reason when refused.
std::optional<std::string> place_workpiece(sim::Bus& bus, std::optional<double> mm, TimePoint now) {
  if (mm && !std::isfinite(*mm)) return "workpiece_mm: a finite position in mm";
  std::vector<std::pair<sim::Controller*, std::optional<double>>> before;
  try {
    for (uint8_t id : bus.ids()) {
      sim::Controller* c = bus.find(id);
      const auto old = c->config().workpiece_mm;
      c->set_workpiece(mm, now);
      before.emplace_back(c, old);
    }
  } catch (const InvalidArgument& e) {
    for (auto& [c, old] : before) c->set_workpiece(old, now);
    return e.what();
  }
  return std::nullopt;
}

}  // namespace

void HttpApi::twin(std::string_view line_name, HttpRequest& request, Responder& responder) {
  Line* line = daemon_.line(line_name);
  if (!line) {
    return void(
        responder.respond(error_response(404, fmt::format("no line called '{}'", line_name))));
  }
  json changes = json::object();
  if (request.method == "POST") {
    try {
      changes = request.body.empty() ? json::object() : json::parse(request.body);
    } catch (const json::exception& e) {
      return void(responder.respond(
          error_response(400, fmt::format("the body is not valid JSON: {}", e.what()))));
    }
    if (!changes.is_object()) {
      return void(responder.respond(error_response(
          400,
          "the body must be a JSON object of twin settings (drop_rate, corrupt_rate, "
          "garbage_rate, workpiece_mm)")));
    }
    for (const auto& [key, value] : changes.items()) {
      if (key == "workpiece_mm") {
        if (!value.is_null() && !value.is_number()) {
          return void(responder.respond(error_response(
              400, "workpiece_mm: a position in mm, or null for no workpiece", key)));
        }
        continue;
      }
      const bool rate = key == "drop_rate" || key == "corrupt_rate" || key == "garbage_rate";
      if (!rate) {
        return void(responder.respond(error_response(
            400,
            fmt::format("'{}' is not a twin setting (drop_rate, corrupt_rate, garbage_rate, "
                        "workpiece_mm)",
                        key),
            key)));
      }
      if (!value.is_number() || value.get<double>() < 0 || value.get<double>() > 1) {
        return void(responder.respond(
            error_response(400, fmt::format("{}: a probability from 0 to 1", key), key)));
      }
    }
  } else if (request.method != "GET") {
    auto r = error_response(405, "method not allowed here (allowed: GET, POST)");
    r.headers.set("Allow", "GET, POST");
    return void(responder.respond(r));
  }
  auto res = responder;
  // The twin belongs to the line's thread: read and change it there.
  line->post_twin([res, changes](sim::Bus* bus, TimePoint now) {
    if (!bus)
      return void(
          res.respond(error_response(404, "this line is not the built-in twin (port: sim)")));
    if (changes.contains("workpiece_mm")) {
      const json& w = changes["workpiece_mm"];
      const std::optional<double> mm =
          w.is_null() ? std::nullopt : std::optional<double>(w.get<double>());
      if (auto refused = place_workpiece(*bus, mm, now)) {
        return void(res.respond(error_response(409, *refused, "workpiece_mm")));
      }
    }
    auto f = bus->faults();
    if (changes.contains("drop_rate")) f.drop = changes["drop_rate"];
    if (changes.contains("corrupt_rate")) f.corrupt = changes["corrupt_rate"];
    if (changes.contains("garbage_rate")) f.garbage = changes["garbage_rate"];
    if (!changes.empty()) bus->set_faults(f);
    res.respond(json_response(200, {{"drop_rate", f.drop},
                                    {"corrupt_rate", f.corrupt},
                                    {"garbage_rate", f.garbage},
                                    {"workpiece_mm", workpiece_of(*bus)},
                                    {"ids", bus->ids()}}));
  });
}

}  // namespace lec6::serve
