// The HTTP API over an AxisDirectory of its own (a twin line, no daemon):
// requests go straight to HttpApi::handle and answers come back through
// Responder::capture, so no socket is needed, except where the test is about
// a browser's connection going away.

#include "http/api/http_api.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <future>
#include <memory>

#include "http/http_server.hpp"
#include "serve/http/http_server_fixture.hpp"
#include "serve/ops/twin_directory.hpp"

namespace lec6::serve {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using testing::eventually;
using ::testing::HasSubstr;
using testing::TwinDirectory;

struct ApiRig {
  explicit ApiRig(bool read_only = false) {
    config.listener.read_only = read_only;
    api = std::make_unique<HttpApi>(axes, axes.ops, config, [](LogLevel, std::string_view) {});
  }
  ~ApiRig() { axes.stop(); }

  // Sends a request from this machine and returns its answer's future.
  std::future<HttpResponse> send(std::string method, std::string target, std::string body = "") {
    HttpRequest r;
    r.method = std::move(method);
    r.target = target;
    const auto split = split_target(target);
    EXPECT_TRUE(split) << target;
    r.path = split->path;
    r.query = split->query;
    r.headers.add("Host", "127.0.0.1:8080");
    if (!body.empty()) r.headers.add("Content-Type", "application/json");
    r.body = std::move(body);
    r.peer = "127.0.0.1:40000";
    r.loopback_peer = true;
    auto promise = std::make_shared<std::promise<HttpResponse>>();
    auto f = promise->get_future();
    api->handle(std::move(r), Responder::capture([promise](HttpResponse response) {
                  promise->set_value(std::move(response));
                }));
    return f;
  }
  // Sends and waits for the answer.
  HttpResponse call(std::string method, std::string target, const json& body = nullptr) {
    auto f = send(std::move(method), std::move(target), body.is_null() ? "" : body.dump());
    EXPECT_EQ(f.wait_for(60s), std::future_status::ready);
    return f.get();
  }

  TwinDirectory axes;
  HttpConfig config;
  std::unique_ptr<HttpApi> api;
};

json body_of(const HttpResponse& r) {
  return json::parse(r.body);
}

const json kSlowMove = {{"position_mm", 390}, {"speed_mm_s", 20}};

TEST(HttpApi, ASecondMoveWhileOneRunsIsRefusedWith409NamingWhoRunsIt) {
  ApiRig rig;
  rig.axes.prepare(rig.axes.axis1());
  const auto first = rig.call("POST", "/api/axes/axis1/move?wait=false", kSlowMove);
  ASSERT_EQ(first.status, 202) << first.body;
  ASSERT_TRUE(eventually([&] { return rig.axes.moving(rig.axes.axis1()); }));

  const auto second = rig.call("POST", "/api/axes/axis1/move", {{"position_mm", 10}});
  EXPECT_EQ(second.status, 409) << second.body;
  EXPECT_THAT(body_of(second).value("error", ""), HasSubstr("axis axis1 is busy: move"));
  EXPECT_THAT(body_of(second).value("error", ""), HasSubstr("http 127.0.0.1"));
  EXPECT_EQ(rig.axes.started("axis1", "move"), 1u) << "the second move never started";
  EXPECT_EQ(rig.call("POST", "/api/axes/axis1/stop").status, 200);
}

TEST(HttpApi, AStopWhileAMoveRunsGoesThroughAndEndsTheMove) {
  ApiRig rig;
  rig.axes.prepare(rig.axes.axis1());
  auto move = rig.send("POST", "/api/axes/axis1/move", kSlowMove.dump());
  ASSERT_TRUE(eventually([&] { return rig.axes.moving(rig.axes.axis1()); }));

  const auto stop = rig.call("POST", "/api/axes/axis1/stop");
  EXPECT_EQ(stop.status, 200) << stop.body;
  ASSERT_EQ(move.wait_for(30s), std::future_status::ready);
  const auto moved = move.get();
  EXPECT_EQ(moved.status, 422) << moved.body;
  EXPECT_EQ(body_of(moved).value("outcome", ""), "stopped") << moved.body;
  const auto s = rig.axes.line1().snapshot(1);
  ASSERT_TRUE(s.state);
  EXPECT_LT(s.state->position_001mm, 39000) << "the axis went on to its target";
}

TEST(HttpApi, AJogWhoseLeaseIsNotRenewedIsReleased) {
  ApiRig rig;
  rig.axes.prepare(rig.axes.axis1());
  const auto jog = rig.call("POST", "/api/axes/axis1/jog", {{"direction", "+"}, {"lease_ms", 300}});
  ASSERT_EQ(jog.status, 200) << jog.body;
  EXPECT_THAT(body_of(jog).value("message", ""), HasSubstr("its lease was not renewed"));
  EXPECT_TRUE(eventually([&] { return !rig.axes.ops.running(rig.axes.axis1()); }));
  EXPECT_TRUE(eventually([&] { return !rig.axes.moving(rig.axes.axis1()); }));
}

TEST(HttpApi, ARenewedJogLeaseKeepsTheJogAndJogStopEndsIt) {
  ApiRig rig;
  rig.axes.prepare(rig.axes.axis1());
  const json hold = {{"direction", "+"}, {"lease_ms", 1500}};
  ASSERT_EQ(rig.call("POST", "/api/axes/axis1/jog?wait=false", hold).status, 202);
  ASSERT_TRUE(eventually([&] { return rig.axes.moving(rig.axes.axis1()); }));
  const auto renewed = rig.call("POST", "/api/axes/axis1/jog", hold);
  EXPECT_EQ(renewed.status, 200) << renewed.body;
  EXPECT_EQ(body_of(renewed).value("message", ""), "jog lease renewed");
  const auto released = rig.call("POST", "/api/axes/axis1/jog-stop");
  EXPECT_EQ(released.status, 200) << released.body;
  EXPECT_EQ(body_of(released).value("message", ""), "jog released");
  EXPECT_TRUE(eventually([&] { return !rig.axes.ops.running(rig.axes.axis1()); }, 5s));
}

TEST(HttpApi, AReadOnlyListenerRefusesWritesAndStillAnswersReads) {
  ApiRig rig(/*read_only=*/true);
  const auto move = rig.call("POST", "/api/axes/axis1/move", {{"position_mm", 10}});
  EXPECT_EQ(move.status, 403) << move.body;
  EXPECT_THAT(body_of(move).value("error", ""), HasSubstr("read-only"));
  EXPECT_EQ(rig.call("POST", "/api/axes/axis1/stop").status, 403);
  EXPECT_TRUE(rig.axes.events().empty()) << "nothing reached the operations";
  const auto info = rig.call("GET", "/api/info");
  ASSERT_EQ(info.status, 200) << info.body;
  EXPECT_TRUE(body_of(info).value("read_only", false));
  EXPECT_EQ(rig.call("GET", "/api/axes/axis1").status, 200);
}

TEST(HttpApi, BadInputIs400NamingTheField) {
  ApiRig rig;
  const auto speed =
      rig.call("POST", "/api/axes/axis1/move", {{"position_mm", 10}, {"speed_mm_s", 70000}});
  EXPECT_EQ(speed.status, 400) << speed.body;
  EXPECT_EQ(body_of(speed).value("field", ""), "speed_mm_s");
  const auto missing = rig.call("POST", "/api/axes/axis1/jog", json::object());
  EXPECT_EQ(missing.status, 400) << missing.body;
  EXPECT_EQ(body_of(missing).value("field", ""), "direction");
  const auto stream =
      rig.call("POST", "/api/axes/axis1/jog", {{"direction", "+"}, {"stream", 12345}});
  EXPECT_EQ(stream.status, 400) << stream.body;
  EXPECT_EQ(body_of(stream).value("field", ""), "stream");
  EXPECT_EQ(rig.call("POST", "/api/axes/nosuch/stop").status, 404);
  EXPECT_TRUE(rig.axes.events().empty()) << "nothing reached the operations";
}

// The browser that holds a jog goes away: its event stream closes and the
// jog is released. A real connection, since that is what goes away.
class HttpApiStream : public testing::ServerFixture {
 protected:
  // The server (the fixture's) stops in TearDown, before these go.
  TwinDirectory axes;
  HttpConfig config;
  HttpApi api{axes, axes.ops, config, [](LogLevel, std::string_view) {}};

  void TearDown() override {
    // The connections close (their streams' callbacks call the API) while
    // the loop still runs, not when the loop is destroyed after the API.
    if (server_) {
      server_->stop();
      EXPECT_TRUE(eventually([&] { return server_->connections() == 0; }));
    }
    ServerFixture::TearDown();
    axes.stop();
  }
};

TEST_F(HttpApiStream, AJogTiedToABrowsersStreamEndsWhenTheBrowserGoesAway) {
  start([this](HttpRequest req, Responder res) { api.handle(std::move(req), std::move(res)); });
  axes.prepare(axes.axis1());

  testing::TestClient browser(port());
  browser.send(testing::get("/api/events", "Accept: text/event-stream\r\n"));
  ASSERT_TRUE(browser.read_until("\n\n"));
  const auto at = browser.buffer().find("{\"stream\":");
  ASSERT_NE(at, std::string::npos) << browser.buffer();
  const auto end = browser.buffer().find('}', at);
  const uint64_t stream = json::parse(browser.buffer().substr(at, end - at + 1))["stream"];

  auto jog = std::make_shared<std::promise<HttpResponse>>();
  auto jogged = jog->get_future();
  HttpRequest r;
  r.method = "POST";
  r.target = r.path = "/api/axes/axis1/jog";
  r.headers.add("Host", "127.0.0.1");
  r.peer = "127.0.0.1:40000";
  r.body = json{{"direction", "+"}, {"lease_ms", 5000}, {"stream", stream}}.dump();
  api.handle(std::move(r), Responder::capture([jog](HttpResponse x) { jog->set_value(x); }));
  ASSERT_TRUE(eventually([&] {
    return axes.moving(axes.axis1()) || jogged.wait_for(0s) == std::future_status::ready;
  }));
  if (jogged.wait_for(200ms) == std::future_status::ready) {
    const HttpResponse early = jogged.get();
    FAIL() << "a 5 s lease, yet answered: " << early.status << " " << early.body;
  }

  browser.close();
  ASSERT_EQ(jogged.wait_for(20s), std::future_status::ready);
  const HttpResponse released = jogged.get();
  EXPECT_EQ(released.status, 200) << released.body;
  EXPECT_THAT(body_of(released).value("message", ""), HasSubstr("connection closed"));
  EXPECT_TRUE(eventually([&] { return !axes.moving(axes.axis1()); }));
}

}  // namespace
}  // namespace lec6::serve
