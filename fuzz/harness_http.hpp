#pragma once
// The http harness: whatever a client may send to `lec serve`'s HTTP port,
// through HttpRequestReader, the static-file path rule and the access rule;
// and SSE framing of arbitrary data. Header-only like harness.hpp, so the
// libFuzzer program (fuzz/fuzz_http.cpp) and the ordinary regression test
// (tests/serve/http/http_fuzz_test.cpp) run the same checks.
//
// Input: [ctl][bytes a client sent]
//   ctl bit 0: small limits (header 256 bytes, body 64) instead of the defaults;
//   ctl seeds the random chunk sizes of the third reading.
//
// Properties:
//   - the same requests (and the same refusal status) however the bytes are
//     cut: all at once, one at a time, in random chunks;
//   - the reader never holds more bytes than it was fed;
//   - a request is well-formed: a method, a path starting with '/', a body
//     within the limit, HTTP/1.0 or 1.1; encoded again it parses to the same
//     method, target, path, query and body;
//   - a refusal is 400, 413, 431 or 505 with a reason;
//   - a static path never has a component that leaves or hides in the root;
//   - reads are never refused for want of a token; writes on a read-only
//     listener always are;
//   - SSE framing of the input read back as a browser would gives the data.

#include <algorithm>
#include <string>
#include <string_view>
#include <vector>

#include "harness.hpp"
#include "http/http_auth.hpp"
#include "http/http_codec.hpp"
#include "http/static_files.hpp"

namespace lec6::fuzz {

namespace http_detail {

using serve::HttpRequest;
using serve::HttpRequestReader;

struct Outcome {
  std::vector<HttpRequest> requests;
  int error_status = 0;  // 0: no error
  std::string reason;

  std::string text() const {
    std::string t = std::to_string(requests.size()) + " requests";
    for (const auto& r : requests) t += " [" + r.method + " " + r.target + "]";
    return t + ", refusal " + std::to_string(error_status) + " " + reason;
  }

  bool same_as(const Outcome& o) const {
    if (error_status != o.error_status || requests.size() != o.requests.size()) return false;
    for (std::size_t i = 0; i < requests.size(); ++i) {
      const auto &a = requests[i], &b = o.requests[i];
      if (a.method != b.method || a.target != b.target || a.body != b.body ||
          a.headers.fields() != b.headers.fields() || a.keep_alive != b.keep_alive)
        return false;
    }
    return true;
  }
};

inline void check_request(const HttpRequest& r, const serve::HttpLimits& limits) {
  check(!r.method.empty(), "a request without a method");
  check(!r.path.empty() && r.path.front() == '/', "a request path that does not start with '/'");
  check(r.body.size() <= limits.body_bytes, "a body over the limit was accepted");
  check(r.version == 10 || r.version == 11, "a request of another HTTP version was accepted");
  check(r.version == 10 || r.headers.has("Host"), "an HTTP/1.1 request without Host");

  // Encoded again, it reads back the same.
  HttpRequestReader again(serve::HttpLimits{1 << 20, 1 << 21});
  check(again.feed(serve::encode_request(r)) == HttpRequestReader::Status::Complete,
        "a request encoded again does not parse");
  const HttpRequest b = again.take();
  check(b.method == r.method && b.target == r.target && b.path == r.path && b.query == r.query &&
            b.body == r.body,
        "a request encoded again reads back different");

  // The static-file rule keeps inside the root.
  if (const auto rel = serve::static_relative_path(r.path)) {
    check(rel->is_relative() && !rel->empty(), "a static path that is not relative");
    for (const auto& part : *rel) {
      const std::string s = part.string();
      check(!s.empty() && s.front() != '.', "a static path with a '.', '..' or dot-file part");
      check(s.find('\\') == std::string::npos && s.find('\0') == std::string::npos,
            "a static path with a backslash or NUL");
    }
  }

  // Reads need no token anywhere; writes on a read-only listener never pass.
  serve::HttpConfig lan;
  lan.listener.listen.address = "0.0.0.0";
  lan.token = "s3cret";
  const auto refusal = serve::check_access(r, lan);
  if (serve::is_read_method(r.method)) check(!refusal, "a read was refused on a LAN listener");
  if (!serve::is_read_method(r.method)) {
    serve::HttpConfig ro = lan;
    ro.listener.read_only = true;
    check(serve::check_access(r, ro).has_value(), "a write passed a read-only listener");
    if (!r.headers.has("Authorization"))
      check(refusal.has_value(), "a write without a token passed a LAN listener");
  }
  if (refusal) check(refusal->status == 401 || refusal->status == 403, "a refusal not 401/403");
}

// Feeds `stream` cut by `next_size` and collects what the reader makes of it.
template <class NextSize>
Outcome read_all(std::string_view stream, const serve::HttpLimits& limits, NextSize next_size) {
  Outcome out;
  HttpRequestReader reader(limits);
  std::size_t fed = 0;
  auto drain = [&] {
    while (reader.status() == HttpRequestReader::Status::Complete) {
      out.requests.push_back(reader.take());
      check_request(out.requests.back(), limits);
      reader.feed({});
    }
  };
  while (fed < stream.size() && reader.status() != HttpRequestReader::Status::Error) {
    const std::size_t n = std::min(next_size(), stream.size() - fed);
    reader.feed(stream.substr(fed, n));
    fed += n;
    check(reader.buffered() <= fed, "the reader holds more bytes than it was fed");
    (void)reader.take_expect_continue();
    drain();
  }
  if (reader.status() == HttpRequestReader::Status::NeedMore) {
    reader.end_of_input();
    drain();
  }
  if (reader.status() == HttpRequestReader::Status::Error) {
    const auto& e = reader.error();
    check(e.status == 400 || e.status == 413 || e.status == 431 || e.status == 505,
          "a refusal with an unexpected status");
    check(!e.reason.empty(), "a refusal without a reason");
    out.error_status = e.status;
    out.reason = e.reason;
  }
  return out;
}

// What a browser's EventSource makes of one event's bytes: the data field.
inline std::string sse_data(std::string_view bytes) {
  std::string data;
  bool first = true;
  std::size_t at = 0;
  while (at < bytes.size()) {
    const auto nl = bytes.find('\n', at);
    const std::string_view line = bytes.substr(at, nl - at);
    at = nl == std::string_view::npos ? bytes.size() : nl + 1;
    if (line.starts_with("data: ")) {
      if (!first) data += '\n';
      data.append(line.substr(6));
      first = false;
    }
  }
  return data;
}

}  // namespace http_detail

inline void http_one(const uint8_t* data, std::size_t size) {
  if (size < 1) return;
  using namespace http_detail;
  const uint8_t ctl = data[0];
  const std::string_view stream(reinterpret_cast<const char*>(data + 1), size - 1);
  const serve::HttpLimits limits = (ctl & 1) ? serve::HttpLimits{256, 64} : serve::HttpLimits{};

  const Outcome whole = read_all(stream, limits, [&] { return stream.size() + 1; });
  const Outcome bytes = read_all(stream, limits, [] { return std::size_t{1}; });
  Rng rng(ctl);
  const Outcome chunks =
      read_all(stream, limits, [&] { return 1 + rng.below(rng.below(4) ? 16 : 700); });
  check(whole.same_as(bytes), "reading byte by byte differs from reading all at once: " +
                                  whole.text() + " / " + bytes.text());
  check(whole.same_as(chunks), "reading in chunks differs from reading all at once: " +
                                   whole.text() + " / " + chunks.text());

  // SSE: the input as an event's data comes back as a browser reads it, with
  // its line ends made \n.
  std::string expected(stream);
  for (std::size_t i = 0; (i = expected.find('\r', i)) != std::string::npos;) {
    if (i + 1 < expected.size() && expected[i + 1] == '\n') {
      expected.erase(i, 1);
    } else {
      expected[i] = '\n';
    }
  }
  const std::string event = serve::encode_event("e", stream, stream.substr(0, 8));
  check(event.ends_with("\n\n"), "an event does not end with a blank line");
  check(event.find("\n\n") == event.size() - 2, "an event holds a blank line before its end");
  check(sse_data(event) == expected, "an event's data does not read back");
}

}  // namespace lec6::fuzz
