// The write rules of the HTTP listeners (see http_auth.hpp).

#include "http/http_auth.hpp"

#include <arpa/inet.h>
#include <fmt/format.h>

#include <string>

namespace lec6::serve {

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// "host:port" / "[v6]:port" / "host" → the host part, brackets kept.
std::string_view host_part(std::string_view authority) {
  if (!authority.empty() && authority.front() == '[') {
    const auto close = authority.find(']');
    return close == std::string_view::npos ? authority : authority.substr(0, close + 1);
  }
  return authority.substr(0, authority.find(':'));
}

HttpResponse unauthorized(std::string_view message, bool wrong_token) {
  auto r = error_response(401, message);
  r.headers.set("WWW-Authenticate", wrong_token ? "Bearer realm=\"lec6\", error=\"invalid_token\""
                                                : "Bearer realm=\"lec6\"");
  return r;
}

// The Origin a browser sent, as "host[:port]" to compare with Host; nullopt
// for "null" or something that is not an origin.
std::optional<std::string_view> origin_authority(std::string_view origin) {
  for (std::string_view scheme : {"http://", "https://"}) {
    if (origin.size() > scheme.size() && iequals(origin.substr(0, scheme.size()), scheme)) {
      std::string_view rest = origin.substr(scheme.size());
      if (rest.find('/') != std::string_view::npos) return std::nullopt;
      return rest;
    }
  }
  return std::nullopt;
}

}  // namespace

bool token_equals(std::string_view given, std::string_view expected) {
  // Every byte of `given` is looked at, whatever matched before.
  unsigned diff = given.size() == expected.size() ? 0u : 1u;
  for (std::size_t i = 0; i < given.size(); ++i) {
    const auto e =
        expected.empty() ? 0u : static_cast<unsigned char>(expected[i % expected.size()]);
    diff |= static_cast<unsigned char>(given[i]) ^ e;
  }
  return diff == 0 && !expected.empty();
}

bool is_loopback_host(std::string_view host) {
  const std::string_view h = host_part(trim(host));
  if (iequals(h, "localhost") || iequals(h, "localhost.")) return true;
  if (h == "[::1]") return true;
  in_addr v4{};
  const std::string text(h);
  return ::inet_pton(AF_INET, text.c_str(), &v4) == 1 && (ntohl(v4.s_addr) >> 24) == 127;
}

std::optional<HttpResponse> check_access(const HttpRequest& request, const HttpConfig& config) {
  const bool loopback_listener = config.listener.listen.loopback();
  const auto host = request.header("Host");
  if (loopback_listener && host && !is_loopback_host(*host)) {
    return error_response(
        403, fmt::format("Host '{}' is not a loopback name: this listener answers to localhost, "
                         "127.0.0.1 and [::1] only (protection against DNS rebinding)",
                         *host));
  }
  if (is_read_method(request.method)) return std::nullopt;

  if (config.listener.read_only) return error_response(403, "this listener is read-only");

  if (const auto origin = request.header("Origin")) {
    const auto authority = origin_authority(trim(*origin));
    if (!authority || !host || !iequals(*authority, trim(*host))) {
      return error_response(
          403, fmt::format("cross-site write refused: Origin '{}' is not this server", *origin));
    }
  }

  // Loopback without a configured token: nothing to check against, and only
  // this machine can reach the listener.
  if (loopback_listener && config.token.empty()) return std::nullopt;

  if (const auto auth = request.header("Authorization")) {
    const std::string_view value = trim(*auth);
    const bool bearer = value.size() > 7 && iequals(value.substr(0, 7), "Bearer ");
    if (!bearer) return unauthorized("the Authorization field must be 'Bearer <token>'", true);
    if (config.token.empty()) {
      return error_response(403,
                            "writes on a listener reachable from other machines need "
                            "http.token in the config");
    }
    if (!token_equals(trim(value.substr(7)), config.token))
      return unauthorized("the token is not the one configured (http.token)", true);
    return std::nullopt;
  }

  if (loopback_listener) return std::nullopt;
  if (config.token.empty()) {
    return error_response(403,
                          "writes on a listener reachable from other machines need "
                          "http.token in the config");
  }
  return unauthorized(
      "writes on this listener need the token: send 'Authorization: Bearer <token>'", false);
}

Router with_access_rules(HttpConfig config, Router inner) {
  return [config = std::move(config), inner = std::move(inner)](HttpRequest request,
                                                                Responder responder) {
    if (auto refusal = check_access(request, config)) {
      responder.respond(std::move(*refusal));
      return;
    }
    inner(std::move(request), std::move(responder));
  };
}

}  // namespace lec6::serve
