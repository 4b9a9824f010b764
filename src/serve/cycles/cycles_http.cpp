#include "cycles/cycles_http.hpp"

#include <fmt/format.h>

#include <atomic>
#include <memory>

namespace lec6::serve {

namespace {

HttpResponse not_allowed_here(std::string_view allow) {
  auto r = error_response(405, fmt::format("method not allowed here (allowed: {})", allow));
  r.headers.set("Allow", std::string(allow));
  return r;
}

}  // namespace

void handle_cycles_http(CycleService* cycles, const std::vector<std::string_view>& parts,
                        const HttpRequest& request, Responder& responder,
                        const std::string& source) {
  const bool get = request.method == "GET" || request.method == "HEAD";
  if (parts.size() == 2) {
    if (!get) return void(responder.respond(not_allowed_here("GET")));
    return void(
        responder.respond(json_response(200, cycles ? cycles->list() : nlohmann::json::array())));
  }
  const std::string name(parts[2]);
  const auto unknown = [&] {
    responder.respond(error_response(
        404, fmt::format("no cycle called '{}' (GET /api/cycles lists them)", name)));
  };
  if (!cycles) return unknown();
  if (parts.size() == 3) {
    if (!get) return void(responder.respond(not_allowed_here("GET")));
    const auto one = cycles->describe(name);
    if (!one) return unknown();
    return void(responder.respond(json_response(200, *one)));
  }
  if (parts.size() != 4 || (parts[3] != "run" && parts[3] != "stop")) {
    return void(responder.respond(
        error_response(404, fmt::format("no such endpoint: {} (run or stop)", request.path))));
  }
  if (request.method != "POST") return void(responder.respond(not_allowed_here("POST")));
  auto res = responder;
  const auto answer = [res](OpResult r) { res.respond(json_response(r.status, r.body)); };
  if (parts[3] == "stop") return cycles->stop(name, source, answer);
  const bool wait = request.query.count("wait") == 0 || request.query.at("wait") != "false";
  if (wait) return cycles->run(name, source, answer);
  // ?wait=false: 202 once it started; a refusal still answers with its status.
  auto once = std::make_shared<std::atomic<bool>>(false);
  cycles->run(name, source, [res, once](OpResult r) {
    if (!once->exchange(true)) res.respond(json_response(r.status, r.body));
  });
  if (!once->exchange(true)) {
    res.respond(json_response(202, {{"ok", true}, {"started", "cycle " + name}}));
  }
}

}  // namespace lec6::serve
