#pragma once
// The HTTP values `lec serve` hands around: a parsed request, the response a
// handler gives back, and the helpers that make the JSON ones. No I/O here:
// http_codec.hpp turns bytes into requests and responses into bytes,
// http_server.hpp moves them over sockets.
//
// Errors follow one shape everywhere on the API, so the dashboard and scripts
// show the same message the CLI would:
//   {"error": "speed_mm_s: 900 is above the actuator's 500 mm/s", "field": "speed_mm_s"}
//
// Thread safety: plain values.

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace lec6::serve {

// Header fields in arrival order; names compare without regard to case
// (RFC 9110 §5.1), values as sent.
class HttpHeaders {
 public:
  void add(std::string name, std::string value);
  // Replaces every field called `name` by one.
  void set(std::string_view name, std::string value);
  void erase(std::string_view name);
  // The first field called `name`.
  std::optional<std::string_view> find(std::string_view name) const;
  bool has(std::string_view name) const { return find(name).has_value(); }
  const std::vector<std::pair<std::string, std::string>>& fields() const { return fields_; }
  bool empty() const { return fields_.empty(); }

 private:
  std::vector<std::pair<std::string, std::string>> fields_;
};

bool iequals(std::string_view a, std::string_view b);

struct HttpRequest {
  std::string method;                        // as sent ("GET"; methods are case-sensitive)
  std::string target;                        // as sent: "/api/axes/x%20y?verbose=1"
  std::string path;                          // percent-decoded, without the query: "/api/axes/x y"
  std::map<std::string, std::string> query;  // decoded ('+' is a space); a repeated key: the last
  HttpHeaders headers;
  std::string body;        // de-chunked
  unsigned version = 11;   // 10 or 11
  bool keep_alive = true;  // what the client asked for (HTTP/1.0 and 1.1 rules)
  std::string peer;        // "127.0.0.1:53422"; empty outside a server
  bool loopback_peer = false;

  std::optional<std::string_view> header(std::string_view name) const { return headers.find(name); }
};

struct HttpResponse {
  int status = 200;
  std::string content_type;  // empty: no Content-Type (e.g. 204, 304)
  std::string body;
  HttpHeaders headers;  // extra fields (Allow, WWW-Authenticate, Cache-Control...)
};

// 200 application/json with `Cache-Control: no-store` (API answers are live data).
HttpResponse json_response(int status, const nlohmann::json& body);
// {"error": message, "field": field} (no "field" when empty).
HttpResponse error_response(int status, std::string_view message, std::string_view field = {});
HttpResponse text_response(int status, std::string body,
                           std::string content_type = "text/plain; charset=utf-8");

// "Not Found" for 404; "Unknown" for a code without a reason phrase.
std::string_view reason_phrase(int status);

// GET, HEAD and OPTIONS read; every other method may change something and
// goes through the write rules of http_auth.hpp.
bool is_read_method(std::string_view method);

// Splits a request target into its decoded path and query. nullopt when the
// target is not origin-form ("/x?y") or absolute-form ("http://h/x?y"), or
// holds a bad or NUL percent escape: the server answers 400.
struct SplitTarget {
  std::string path;
  std::map<std::string, std::string> query;
};
std::optional<SplitTarget> split_target(std::string_view target);
// %XX decoding; '+' becomes a space when `plus_is_space`. nullopt on a bad
// escape or an encoded NUL.
std::optional<std::string> percent_decode(std::string_view text, bool plus_is_space);

}  // namespace lec6::serve
