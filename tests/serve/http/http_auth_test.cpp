// The write rules of http_auth.hpp, as a table.

#include "http/http_auth.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

namespace lec6::serve {
namespace {

HttpConfig listener(const std::string& address, bool read_only, const std::string& token) {
  HttpConfig c;
  c.listener.listen.address = address;
  c.listener.listen.port = 8080;
  c.listener.read_only = read_only;
  c.token = token;
  return c;
}

struct Case {
  const char* what;
  HttpConfig config;
  const char* method;
  std::vector<std::pair<std::string, std::string>> headers;
  int status;           // 0: allowed
  const char* message;  // part of the error
};

TEST(CheckAccess, FollowsTheTable) {
  const auto lo = listener("127.0.0.1", false, "");
  const auto lo_token = listener("127.0.0.1", false, "s3cret");
  const auto lo_ro = listener("127.0.0.1", true, "");
  const auto lan = listener("0.0.0.0", false, "s3cret");
  const auto lan_ro = listener("0.0.0.0", true, "");
  const auto lan_no_token = listener("192.0.2.1", false, "");
  using H = std::vector<std::pair<std::string, std::string>>;
  const H host_lo = {{"Host", "127.0.0.1:8080"}};
  const H lan_host = {{"Host", "lec6.lab:8080"}};
  auto with = [](H h, std::string name, std::string value) {
    h.emplace_back(std::move(name), std::move(value));
    return h;
  };
  const Case cases[] = {
      {"GET on loopback", lo, "GET", host_lo, 0, ""},
      {"GET on a LAN listener needs no token", lan, "GET", lan_host, 0, ""},
      {"HEAD on read-only", lo_ro, "HEAD", host_lo, 0, ""},
      {"POST on loopback", lo, "POST", host_lo, 0, ""},
      {"POST on loopback, any Authorization ignored without a token", lo, "POST",
       with(host_lo, "Authorization", "Basic eDp5"), 0, ""},
      {"DELETE on read-only loopback", lo_ro, "DELETE", host_lo, 403, "read-only"},
      {"PUT on read-only LAN", lan_ro, "PUT", lan_host, 403, "read-only"},
      {"POST on LAN without token", lan, "POST", lan_host, 401, "need the token"},
      {"POST on LAN, right token", lan, "POST", with(lan_host, "Authorization", "Bearer s3cret"), 0,
       ""},
      {"POST on LAN, scheme any case", lan, "POST",
       with(lan_host, "authorization", "bearer s3cret"), 0, ""},
      {"POST on LAN, wrong token", lan, "POST", with(lan_host, "Authorization", "Bearer s3cre"),
       401, "not the one configured"},
      {"POST on LAN, token too long", lan, "POST",
       with(lan_host, "Authorization", "Bearer s3cretX"), 401, "not the one configured"},
      {"POST on LAN, Basic", lan, "POST", with(lan_host, "Authorization", "Basic eDp5"), 401,
       "Bearer"},
      {"POST on LAN, no token configured", lan_no_token, "POST", lan_host, 403, "http.token"},
      {"POST on loopback with a token, none given", lo_token, "POST", host_lo, 0, ""},
      {"POST on loopback with a token, right one", lo_token, "POST",
       with(host_lo, "Authorization", "Bearer s3cret"), 0, ""},
      {"POST on loopback with a token, wrong one", lo_token, "POST",
       with(host_lo, "Authorization", "Bearer nope"), 401, "not the one configured"},
      {"POST from a same-origin page", lo, "POST", with(host_lo, "Origin", "http://127.0.0.1:8080"),
       0, ""},
      {"POST from another site", lo, "POST", with(host_lo, "Origin", "http://evil.example"), 403,
       "cross-site"},
      {"POST from an opaque origin", lo, "POST", with(host_lo, "Origin", "null"), 403,
       "cross-site"},
      {"GET from another site is a read", lo, "GET", with(host_lo, "Origin", "http://evil.example"),
       0, ""},
      {"DNS rebinding: a foreign Host on loopback",
       lo,
       "GET",
       {{"Host", "evil.example:8080"}},
       403,
       "DNS rebinding"},
      {"localhost by name", lo, "POST", {{"Host", "localhost:8080"}}, 0, ""},
      {"[::1]", lo, "POST", {{"Host", "[::1]:8080"}}, 0, ""},
      {"HTTP/1.0 without Host", lo, "POST", {}, 0, ""},
  };
  for (const auto& c : cases) {
    HttpRequest r;
    r.method = c.method;
    r.path = "/api/x";
    for (const auto& [n, v] : c.headers) r.headers.add(n, v);
    const auto refusal = check_access(r, c.config);
    if (c.status == 0) {
      EXPECT_FALSE(refusal) << c.what << ": " << (refusal ? refusal->body : "");
      continue;
    }
    ASSERT_TRUE(refusal) << c.what;
    EXPECT_EQ(refusal->status, c.status) << c.what;
    const std::string error = nlohmann::json::parse(refusal->body).at("error");
    EXPECT_NE(error.find(c.message), std::string::npos) << c.what << ": " << error;
    if (c.status == 401) {
      EXPECT_TRUE(refusal->headers.find("WWW-Authenticate").value_or("").starts_with("Bearer"))
          << c.what;
    }
  }
}

TEST(WithAccessRules, ARefusedRequestNeverReachesTheRouter) {
  int reached = 0;
  const Router guarded =
      with_access_rules(listener("127.0.0.1", true, ""), [&](HttpRequest, Responder res) {
        ++reached;
        res.respond(text_response(200, "ok"));
      });
  auto ask = [&](const char* method) {
    HttpRequest r;
    r.method = method;
    r.headers.add("Host", "127.0.0.1:8080");
    int status = 0;
    guarded(r, Responder::capture([&](HttpResponse resp) { status = resp.status; }));
    return status;
  };
  EXPECT_EQ(ask("POST"), 403);
  EXPECT_EQ(reached, 0);
  EXPECT_EQ(ask("GET"), 200);
  EXPECT_EQ(reached, 1);
}

TEST(TokenEquals, ComparesWholeTokens) {
  EXPECT_TRUE(token_equals("abc", "abc"));
  EXPECT_FALSE(token_equals("abd", "abc"));
  EXPECT_FALSE(token_equals("ab", "abc"));
  EXPECT_FALSE(token_equals("abcabc", "abc"));
  EXPECT_FALSE(token_equals("", ""));
  EXPECT_FALSE(token_equals("x", ""));
}

TEST(IsLoopbackHost, KnowsTheLoopbackNames) {
  EXPECT_TRUE(is_loopback_host("localhost"));
  EXPECT_TRUE(is_loopback_host("LOCALHOST:80"));
  EXPECT_TRUE(is_loopback_host("127.0.0.1:8080"));
  EXPECT_TRUE(is_loopback_host("127.1.2.3"));
  EXPECT_TRUE(is_loopback_host("[::1]:8080"));
  EXPECT_FALSE(is_loopback_host("127.0.0.1.evil.example"));
  EXPECT_FALSE(is_loopback_host("localhost.evil.example"));
  EXPECT_FALSE(is_loopback_host("10.0.0.1"));
  EXPECT_FALSE(is_loopback_host(""));
}

}  // namespace
}  // namespace lec6::serve
