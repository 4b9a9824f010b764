#include "http/api/http_api.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "cycles/cycles_http.hpp"    // issue 34
#include "history/history.hpp"       // issue 26
#include "history/history_http.hpp"  // issue 26
#include "http/http_auth.hpp"
#include "ops/op_results.hpp"
#include "ops/views.hpp"

namespace lec6::serve {
namespace {

using nlohmann::json;

std::vector<std::string_view> segments(std::string_view path) {
  std::vector<std::string_view> out;
  while (!path.empty()) {
    const auto slash = path.find('/');
    if (slash != 0) out.push_back(path.substr(0, slash));
    if (slash == std::string_view::npos) break;
    path.remove_prefix(slash + 1);
  }
  return out;
}

HttpResponse op_response(const OpResult& r) {
  return json_response(r.status, r.body);
}

HttpResponse method_not_allowed(std::string_view allow) {
  auto r = error_response(405, fmt::format("method not allowed here (allowed: {})", allow));
  r.headers.set("Allow", std::string(allow));
  return r;
}

// The request's JSON body; an empty body is `{}`.
std::optional<json> body_json(const HttpRequest& req, Responder& res) {
  if (req.body.empty()) return json::object();
  try {
    return json::parse(req.body);
  } catch (const json::exception& e) {
    res.respond(error_response(400, fmt::format("the body is not valid JSON: {}", e.what())));
    return std::nullopt;
  }
}

}  // namespace

// ---- events ---------------------------------------------------------------------

void EventHub::add(EventStream stream) {
  std::lock_guard lock(mutex_);
  streams_.push_back(std::move(stream));
}

void EventHub::broadcast(std::string_view event, const std::string& data,
                         EventStream::Delivery delivery) {
  std::vector<EventStream> streams;
  {
    std::lock_guard lock(mutex_);
    std::erase_if(streams_, [](const EventStream& s) { return s.closed(); });
    streams = streams_;
  }
  for (const auto& s : streams) s.send(event, data, delivery);
}

std::size_t EventHub::size() const {
  std::lock_guard lock(mutex_);
  return streams_.size();
}

// ---- the API ----------------------------------------------------------------------

std::filesystem::path default_web_root() {
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return {};
  const auto dir = exe.parent_path();
  for (const auto& candidate : {dir / "web", dir.parent_path() / "share" / "lec6" / "web"}) {
    if (std::filesystem::exists(candidate / "index.html", ec)) return candidate;
  }
  return {};
}

HttpApi::HttpApi(const AxisDirectory& directory, Operations& ops, const HttpConfig& config, Log log,
                 CycleService* cycles)
    : directory_(directory), ops_(ops), cycles_(cycles), config_(config), log_(std::move(log)) {
  const auto root = config_.web_root.empty() ? default_web_root() : config_.web_root;
  if (!root.empty()) files_ = std::make_unique<StaticFiles>(root);
  for (const AxisRef& axis : directory_.axes()) {
    axis.line->add_observer([this, axis](const TelemetryEvent& e, const AxisSnapshot& s) {
      if (e.id != axis.id || (e.block != Block::State && !e.flags_changed && !e.online_changed)) {
        return;
      }
      events_.broadcast("telemetry", telemetry_json(axis, s).dump());
    });
  }
  ops_.add_observer([this](const std::string& axis, const json& event) {
    json e = event;
    e["axis"] = axis;
    events_.broadcast("op", e.dump(), EventStream::Delivery::Reliable);
  });
  // issue 26: history, drift and health events (history/history.hpp).
  if (auto* h = directory_.history()) {
    h->add_listener([this](const std::string& axis, std::string_view kind, const json& j) {
      json e = j;
      e["axis"] = axis;
      events_.broadcast(kind, e.dump(), EventStream::Delivery::Reliable);
    });
  }
}

std::string HttpApi::source(const HttpRequest& request) const {
  const auto colon = request.peer.rfind(':');
  return "http " + (colon == std::string::npos ? request.peer : request.peer.substr(0, colon));
}

void HttpApi::publish_stats() {
  if (events_.size() == 0) return;
  json lines = json::array();
  for (const auto& c : directory_.lines()) {
    lines.push_back({{"name", c.name}, {"stats", stats_json(directory_.line(c.name)->stats(), c)}});
  }
  events_.broadcast("stats", json{{"lines", lines}}.dump());
}

void HttpApi::open_events(Responder& responder) {
  EventStream stream = responder.open_stream();
  const uint64_t id = next_stream_++;
  // The stream's id ties a hold-to-run jog to this browser (see jog).
  stream.send("hello", json{{"stream", id}}.dump(), EventStream::Delivery::Reliable);
  for (const AxisRef& axis : directory_.axes()) {
    stream.send("telemetry", telemetry_json(axis, axis.line->snapshot(axis.id)).dump());
  }
  events_.add(stream);
  std::lock_guard lock(streams_mutex_);
  streams_by_id_[id] = stream;
  stream.on_close([this, id] {
    std::lock_guard lock(streams_mutex_);
    streams_by_id_.erase(id);
  });
}

void HttpApi::handle(HttpRequest request, Responder responder) {
  if (auto refused = check_access(request, config_)) return void(responder.respond(*refused));
  const auto parts = segments(request.path);
  const bool get = request.method == "GET" || request.method == "HEAD";
  if (request.path == "/metrics") {
    if (!get) return void(responder.respond(method_not_allowed("GET")));
    return void(responder.respond(text_response(200, prometheus_metrics(directory_),
                                                "text/plain; version=0.0.4; charset=utf-8")));
  }
  if (parts.empty() || parts[0] != "api") {
    if (files_) return void(responder.respond(files_->serve(request)));
    return void(responder.respond(error_response(
        404, "the dashboard is not installed here: build it with `make web`; the API is at /api")));
  }
  if (parts.size() == 2 && parts[1] == "info") {
    if (!get) return void(responder.respond(method_not_allowed("GET")));
    // What a page needs to know before it offers any control.
    const bool loopback = config_.listener.listen.loopback();
    json lines = json::array();
    for (const auto& c : directory_.lines()) lines.push_back(c.name);
    return void(responder.respond(json_response(
        200, {{"read_only", config_.listener.read_only},
              {"token_required", !config_.listener.read_only && !config_.token.empty()},
              {"listener_loopback", loopback},
              {"lines", lines},
              {"axes", directory_.axes().size()}})));
  }
  if (parts.size() >= 2 && parts[1] == "cycles") {  // issue 34
    return handle_cycles_http(cycles_, parts, request, responder, source(request));
  }
  if (parts.size() == 2 && parts[1] == "fields") {
    if (!get) return void(responder.respond(method_not_allowed("GET")));
    return void(responder.respond(json_response(200, step_fields_json())));
  }
  if (parts.size() == 2 && parts[1] == "events") {
    if (!get) return void(responder.respond(method_not_allowed("GET")));
    return open_events(responder);
  }
  if (parts.size() == 2 && parts[1] == "lines") {
    if (!get) return void(responder.respond(method_not_allowed("GET")));
    json out = json::array();
    for (const auto& c : directory_.lines()) out.push_back(line_json(c, *directory_.line(c.name)));
    return void(responder.respond(json_response(200, out)));
  }
  if (parts.size() == 4 && parts[1] == "lines" && parts[3] == "twin") {
    return twin(parts[2], request, responder);
  }
  if (parts.size() == 2 && parts[1] == "axes") {
    if (!get) return void(responder.respond(method_not_allowed("GET")));
    json out = json::array();
    for (const auto& a : directory_.axes()) out.push_back(axis_json(a, &ops_));
    return void(responder.respond(json_response(200, out)));
  }
  if (parts.size() >= 3 && parts[1] == "axes") {
    const AxisRef* axis = directory_.axis(parts[2]);
    if (!axis) {
      return void(responder.respond(error_response(
          404, fmt::format("no axis called '{}' (GET /api/axes lists them)", parts[2]))));
    }
    return route_axis(*axis, {parts.begin() + 3, parts.end()}, request, responder);
  }
  responder.respond(error_response(404, fmt::format("no such endpoint: {}", request.path)));
}

void HttpApi::route_axis(const AxisRef& axis, std::vector<std::string_view> rest,
                         HttpRequest& request, Responder& responder) {
  const bool get = request.method == "GET" || request.method == "HEAD";
  if (rest.empty()) {
    if (!get) return void(responder.respond(method_not_allowed("GET")));
    return void(responder.respond(json_response(200, axis_json(axis, &ops_))));
  }
  if (rest[0] == "steps") return steps(axis, {rest.begin() + 1, rest.end()}, request, responder);
  // issue 26: history, health (history/history_http.hpp)
  if (history::handle_http(directory_.history(), axis, rest, request, responder)) return;
  if (rest.size() == 1 && rest[0] == "alarms") {
    if (!get) return void(responder.respond(method_not_allowed("GET")));
    const json a = axis_json(axis);
    return void(responder.respond(
        json_response(200, {{"alarms", a["alarms"]}, {"history", a["alarm_history"]}})));
  }
  if (rest.size() == 1) {
    if (request.method != "POST") return void(responder.respond(method_not_allowed("POST")));
    return command(axis, rest[0], request, responder);
  }
  responder.respond(error_response(404, fmt::format("no such endpoint: {}", request.path)));
}

void HttpApi::command(const AxisRef& axis, std::string_view op, HttpRequest& request,
                      Responder& responder) {
  auto args = body_json(request, responder);
  if (!args) return;
  // A hold-to-run jog may name the event stream of the browser holding it.
  std::optional<EventStream> stream;
  if (args->is_object() && args->contains("stream")) {
    const json& id = (*args)["stream"];
    std::lock_guard lock(streams_mutex_);
    const auto it =
        id.is_number_unsigned() ? streams_by_id_.find(id.get<uint64_t>()) : streams_by_id_.end();
    if (it == streams_by_id_.end()) {
      return void(responder.respond(error_response(
          400, "stream: no open event stream has this id (GET /api/events gives one)", "stream")));
    }
    stream = it->second;
    args->erase("stream");
  }
  auto cmd = parse_command(op, *args);
  if (!cmd) {
    const int status = cmd.error().field == "op" ? 404 : 400;
    return void(responder.respond(error_response(status, cmd.error().message, cmd.error().field)));
  }
  const bool wait = request.query.count("wait") == 0 || request.query.at("wait") != "false";
  const Op kind = cmd->op;
  auto res = responder;
  if (!wait) {
    ops_.run(axis, std::move(*cmd), source(request), [](OpResult) {});
    res.respond(json_response(202, {{"ok", true}, {"started", op_name(kind)}}));
  } else {
    ops_.run(axis, std::move(*cmd), source(request),
             [res](OpResult r) { res.respond(op_response(r)); });
  }
  if (kind == Op::Jog && stream) {
    // A hold-to-run jog ends when the browser that holds it goes away.
    ops_.tie_jog(axis.name, [s = *stream] { return s.closed(); });
  }
}

}  // namespace lec6::serve
