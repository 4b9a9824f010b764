// HttpServer over real sockets on 127.0.0.1: requests and answers, late
// answers from other threads, connection limits, timeouts, stop().

#include <gtest/gtest.h>

#include <cstdio>
#include <future>
#include <nlohmann/json.hpp>

#include "http_server_fixture.hpp"

namespace lec6::serve::testing {
namespace {

using HttpServerTest = ServerFixture;

TEST_F(HttpServerTest, AnswersAGetAndKeepsTheConnectionForTheNext) {
  start(sample_router);
  TestClient c(port());
  c.send(get("/hello"));
  auto r = c.read_response();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->header("content-type"), "application/json");
  EXPECT_EQ(nlohmann::json::parse(r->body), (nlohmann::json{{"hello", "world"}}));
  c.send("POST /hello HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 3\r\n\r\nabc");
  auto again = c.read_response();
  ASSERT_TRUE(again) << "keep-alive: the same connection answers again";
  const auto j = nlohmann::json::parse(again->body);
  EXPECT_EQ(j.at("got"), "abc");
  EXPECT_EQ(j.at("peer_loopback"), true);
  c.send("HEAD /hello HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
  auto head = c.read_response(true);
  ASSERT_TRUE(head);
  EXPECT_EQ(head->header("content-length"), std::to_string(r->body.size()));
  EXPECT_TRUE(head->body.empty());
}

TEST_F(HttpServerTest, TheSampleRouterAnswers404And405) {
  start(sample_router);
  TestClient c(port());
  c.send(get("/nope"));
  auto r = c.read_response();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 404);
  EXPECT_EQ(nlohmann::json::parse(r->body).at("error"), "no such endpoint: /nope");
  c.send("DELETE /hello HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
  auto d = c.read_response();
  ASSERT_TRUE(d);
  EXPECT_EQ(d->status, 405);
  EXPECT_EQ(d->header("allow"), "GET, HEAD, POST");
}

TEST_F(HttpServerTest, AHandlerMayAnswerLaterFromAnotherThread) {
  std::promise<Responder> parked;
  start([&](HttpRequest, Responder res) { parked.set_value(res); });
  TestClient c(port());
  c.send(get("/slow"));
  auto future = parked.get_future();
  ASSERT_EQ(future.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  Responder res = future.get();
  EXPECT_FALSE(res.answered());
  std::thread worker([res] { res.respond(text_response(202, "queued")); });
  worker.join();
  EXPECT_TRUE(res.answered());
  EXPECT_FALSE(res.respond(text_response(200, "twice"))) << "one answer per request";
  auto r = c.read_response();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 202);
  EXPECT_EQ(r->body, "queued");
}

TEST_F(HttpServerTest, ADroppedResponderOrAThrowingHandlerAnswers500) {
  start([](HttpRequest req, Responder res) {
    if (req.path == "/throw") throw std::runtime_error("boom");
    if (req.path == "/ok") res.respond(text_response(200, "ok"));
    // otherwise: the responder is dropped unanswered
  });
  TestClient c(port());
  c.send(get("/drop"));
  auto dropped = c.read_response();
  ASSERT_TRUE(dropped);
  EXPECT_EQ(dropped->status, 500);
  EXPECT_NE(dropped->body.find("not answered"), std::string::npos);
  c.send(get("/throw"));
  auto thrown = c.read_response();
  ASSERT_TRUE(thrown);
  EXPECT_EQ(thrown->status, 500);
  EXPECT_NE(thrown->body.find("boom"), std::string::npos);
  c.send(get("/ok"));
  auto ok = c.read_response();
  ASSERT_TRUE(ok) << "the connection survives a failed handler";
  EXPECT_EQ(ok->status, 200);
  std::lock_guard lock(log_mutex_);
  ASSERT_EQ(log_.size(), 1u);
  EXPECT_NE(log_[0].find("GET /throw"), std::string::npos) << log_[0];
}

TEST_F(HttpServerTest, PipelinedRequestsAreAnsweredInOrder) {
  start([](HttpRequest req, Responder res) { res.respond(text_response(200, req.path)); });
  TestClient c(port());
  c.send(get("/1") + get("/2") + get("/3"));
  for (const char* want : {"/1", "/2", "/3"}) {
    auto r = c.read_response();
    ASSERT_TRUE(r);
    EXPECT_EQ(r->body, want);
  }
}

TEST_F(HttpServerTest, ABadRequestGetsItsStatusAndTheConnectionCloses) {
  HttpServerOptions options;
  options.limits.body_bytes = 100;
  start(sample_router, options);
  {
    TestClient c(port());
    c.send("POST /hello HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 5000\r\n\r\n" +
           std::string(5000, 'x'));
    auto r = c.read_response();
    ASSERT_TRUE(r) << "the answer survives the body still arriving";
    EXPECT_EQ(r->status, 413);
    EXPECT_EQ(r->header("connection"), "close");
    EXPECT_TRUE(c.wait_closed());
  }
  TestClient garbage(port());
  garbage.send("\x16\x03\x01 not http at all\r\n\r\n");
  auto r = garbage.read_response();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  EXPECT_TRUE(garbage.wait_closed());
}

TEST_F(HttpServerTest, Sends100ContinueBeforeReadingAnExpectedBody) {
  start(sample_router);
  TestClient c(port());
  c.send(
      "POST /hello HTTP/1.1\r\nHost: 127.0.0.1\r\nExpect: 100-continue\r\nContent-Length: "
      "2\r\n\r\n");
  auto interim = c.read_response();
  ASSERT_TRUE(interim);
  EXPECT_EQ(interim->status, 100);
  c.send("hi");
  auto r = c.read_response();
  ASSERT_TRUE(r);
  EXPECT_EQ(nlohmann::json::parse(r->body).at("got"), "hi");
}

TEST_F(HttpServerTest, Http10ClosesUnlessAskedToKeepAlive) {
  start(sample_router);
  TestClient c(port());
  c.send("GET /hello HTTP/1.0\r\n\r\n");
  auto r = c.read_response();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_TRUE(c.wait_closed());
}

TEST_F(HttpServerTest, ConnectionsOverTheCapGet503) {
  HttpServerOptions options;
  options.max_connections = 2;
  start(sample_router, options);
  TestClient a(port()), b(port());
  for (TestClient* c : {&a, &b}) {
    c->send(get("/hello"));
    ASSERT_TRUE(c->read_response());
  }
  EXPECT_EQ(server_->connections(), 2u);
  {
    TestClient third(port());
    auto r = third.read_response();
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 503);
    EXPECT_NE(r->body.find("too many connections (at most 2)"), std::string::npos);
    EXPECT_TRUE(third.wait_closed());
  }
  a.close();
  ASSERT_TRUE(eventually([&] { return server_->connections() == 1; }));
  TestClient fourth(port());
  fourth.send(get("/hello"));
  auto r = fourth.read_response();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << "a freed place is given to the next";
}

TEST_F(HttpServerTest, AnIdleConnectionIsClosedAfterTheIdleTimeout) {
  HttpServerOptions options;
  options.idle_timeout = std::chrono::milliseconds(200);
  start(sample_router, options);
  TestClient c(port());
  // The server arms its idle timer once the answer is written, which the client
  // cannot see; the request's send is the last instant the client knows to be
  // before it (timing the read of the answer raced the timer under load).
  const auto asked = std::chrono::steady_clock::now();
  c.send(get("/hello"));
  ASSERT_TRUE(c.read_response());
  EXPECT_TRUE(c.wait_closed());
  EXPECT_GE(std::chrono::steady_clock::now() - asked, std::chrono::milliseconds(200))
      << "closed before the idle timeout";
  EXPECT_TRUE(eventually([&] { return server_->connections() == 0; }));
}

TEST_F(HttpServerTest, StopClosesTheListenerAndEveryConnection) {
  std::promise<Responder> parked;
  start([&](HttpRequest req, Responder res) {
    if (req.path == "/park") {
      parked.set_value(res);
    } else {
      sample_router(std::move(req), res);
    }
  });
  const uint16_t p = port();
  TestClient idle(p), waiting(p);
  idle.send(get("/hello"));
  ASSERT_TRUE(idle.read_response());
  waiting.send(get("/park"));
  auto future = parked.get_future();
  ASSERT_EQ(future.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  server_->stop();
  EXPECT_TRUE(idle.wait_closed());
  EXPECT_TRUE(waiting.wait_closed());
  EXPECT_TRUE(eventually([&] { return !TestClient::can_connect(p); }));
  EXPECT_FALSE(future.get().respond(text_response(200, "too late")));
  EXPECT_EQ(server_->connections(), 0u);
}

TEST_F(HttpServerTest, APortInUseIsAClearError) {
  start(sample_router);
  ListenerConfig same;
  same.listen.port = port();
  try {
    HttpServer second(io_, same, sample_router);
    FAIL() << "bound a port already in use";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(
        std::string(e.what()).find("cannot listen for HTTP on 127.0.0.1:" + std::to_string(port())),
        std::string::npos)
        << e.what();
  }
}

// curl, the client the API's users and integration tests use.
std::string run(const std::string& command) {
  std::string out;
  FILE* p = ::popen(command.c_str(), "r");
  if (!p) return out;
  char buf[4096];
  while (std::size_t n = std::fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  ::pclose(p);
  return out;
}

TEST_F(HttpServerTest, CurlGetsAndPostsThroughIt) {
  start(sample_router);
  const std::string base = "http://127.0.0.1:" + std::to_string(port());
  EXPECT_EQ(run("curl -sS --max-time 10 " + base + "/hello"), R"({"hello":"world"})");
  const std::string posted = run("curl -sS --max-time 10 -X POST --data-binary @- " + base +
                                 "/hello -w ' %{http_code}' < /dev/null");
  EXPECT_EQ(posted, R"({"got":"","peer_loopback":true} 200)");
  // Over 1 KiB: curl sends Expect: 100-continue and waits for it.
  const std::string big =
      run("head -c 5000 /dev/zero | tr '\\0' a | curl -sS --max-time 10 "
          "--data-binary @- " +
          base + "/hello -w ' %{time_total}'");
  ASSERT_NE(big.find(std::string(5000, 'a')), std::string::npos) << big.substr(0, 200);
  EXPECT_LT(std::stod(big.substr(big.rfind(' ') + 1)), 0.9)
      << "curl waited for a 100 Continue that did not come";
  EXPECT_EQ(run("curl -s -o /dev/null -w '%{http_code}' --max-time 10 " + base + "/missing"),
            "404");
}

}  // namespace
}  // namespace lec6::serve::testing
