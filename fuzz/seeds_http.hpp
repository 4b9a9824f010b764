#pragma once
// Seed inputs for the http harness (harness_http.hpp): real requests as a
// browser, curl and the dashboard send them, plus the awkward legal ones
// (pipelined, chunked, HTTP/1.0, absolute-form, 100-continue). Input format:
// [ctl][request bytes]. fuzz/make_seeds writes them; the regression test
// (tests/serve/http/http_fuzz_test.cpp) runs each through the harness.

#include <string>
#include <utility>
#include <vector>

namespace lec6::fuzz {

inline std::vector<std::pair<std::string, std::string>> http_seeds() {
  const std::vector<std::pair<std::string, std::string>> requests = {
      {"browser-get",
       "GET /assets/index-4f3a2b1c.js HTTP/1.1\r\nHost: 127.0.0.1:8080\r\n"
       "User-Agent: Mozilla/5.0\r\nAccept: */*\r\nAccept-Encoding: gzip, deflate, br\r\n"
       "Connection: keep-alive\r\nIf-None-Match: \"1a-2b\"\r\n\r\n"},
      {"curl-post-json",
       "POST /api/axes/axis1/move HTTP/1.1\r\nHost: localhost:8080\r\nUser-Agent: curl/7.88.1\r\n"
       "Accept: */*\r\nContent-Type: application/json\r\nAuthorization: Bearer s3cret\r\n"
       "Content-Length: 38\r\n\r\n{\"position_mm\": 120.5, \"speed\": 50.0}"},
      {"event-stream",
       "GET /api/events?axes=axis1,axis2 HTTP/1.1\r\nHost: 127.0.0.1:8080\r\n"
       "Accept: text/event-stream\r\nCache-Control: no-cache\r\nLast-Event-ID: 41\r\n\r\n"},
      {"pipelined",
       "GET /api/axes HTTP/1.1\r\nHost: h\r\n\r\nHEAD / HTTP/1.1\r\nHost: h\r\n\r\n"
       "DELETE /api/jobs/7 HTTP/1.1\r\nHost: h\r\nContent-Length: 0\r\n\r\n"},
      {"chunked",
       "PUT /api/axes/a%20b/steps/3 HTTP/1.1\r\nHost: h\r\nTransfer-Encoding: chunked\r\n"
       "Origin: http://h\r\n\r\n4\r\n{\"a\"\r\n3;x=y\r\n:1}\r\n0\r\nTrailer: t\r\n\r\n"},
      {"http10", "GET /metrics HTTP/1.0\r\nUser-Agent: Prometheus/2.42\r\n\r\n"},
      {"absolute-form",
       "GET http://127.0.0.1:8080/api/version?x=%41&y=a+b HTTP/1.1\r\nHost: x\r\n\r\n"},
      {"expect-continue",
       "POST /api/steps HTTP/1.1\r\nHost: h\r\nExpect: 100-continue\r\nContent-Length: 4\r\n\r\n"
       "abcd"},
      {"traversal", "GET /%2e%2e/%2E%2e/etc/passwd HTTP/1.1\r\nHost: h\r\n\r\n"},
      {"foreign-host",
       "POST /api/stop HTTP/1.1\r\nHost: evil.example\r\nContent-Length: 0\r\n\r\n"},
  };
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& [name, text] : requests) {
    out.emplace_back(name, std::string(1, '\0') + text);               // whole, default limits
    out.emplace_back(name + "-small", std::string(1, '\x37') + text);  // small limits, chunks
  }
  return out;
}

}  // namespace lec6::fuzz
