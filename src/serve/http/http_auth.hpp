#pragma once
// Who may do what over HTTP. One function decides, for every request, before
// any handler sees it; the API calls it first.
//
// Reads (GET, HEAD, OPTIONS) never need a token: the dashboard, scripts and
// Prometheus must be able to look without a secret, and a read moves nothing.
// Writes (every other method) follow, in this order:
//   1. a read-only listener refuses them: 403 "this listener is read-only";
//   2. a browser's cross-site write (an Origin that is not this server) is
//      refused: 403 (a web page the user visits must not drive an axis);
//   3. a token given (Authorization: Bearer <token>) must be the configured
//      one, on any listener: 401 otherwise;
//   4. with no token given: a loopback listener lets the write through (only
//      this machine can reach it); a listener reachable from other machines
//      answers 401 with WWW-Authenticate (403 if no token is configured at all:
//      load_config refuses that, but the rule does not rely on it).
// And for every request on a loopback listener: a Host that is not a loopback
// name (localhost, 127.x.y.z, [::1]) is refused, 403: otherwise a web page
// could reach the daemon through DNS rebinding.
//
// Tokens are compared in constant time.
//
// Thread safety: pure functions.

#include <optional>
#include <string_view>

#include "http/http.hpp"
#include "http/http_server.hpp"
#include "lec6/serve/config.hpp"

namespace lec6::serve {

// nullopt: go ahead; otherwise the refusal to send as it is.
std::optional<HttpResponse> check_access(const HttpRequest& request, const HttpConfig& config);

// `inner` behind the rules: a refused request is answered here and never
// reaches it. What HttpServer is given for a listener.
Router with_access_rules(HttpConfig config, Router inner);

// Whether a Host field names this machine's loopback ("localhost:8080",
// "127.0.0.1", "[::1]:8080").
bool is_loopback_host(std::string_view host);

// Constant-time equality (in the length of `given`): timing tells nothing
// about how much of a guessed token was right.
bool token_equals(std::string_view given, std::string_view expected);

}  // namespace lec6::serve
