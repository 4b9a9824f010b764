// Server-Sent Events: the bounded queue on its own, then streams over real
// sockets (events arrive, the browser leaving is noticed, a slow browser
// loses old telemetry instead of blocking the sender, heartbeats, stop()).

#include <gtest/gtest.h>

#include <atomic>
#include <future>

#include "http/http_stream_state.hpp"
#include "http_server_fixture.hpp"

namespace lec6::serve::testing {
namespace {

TEST(StreamState, DropsTheOldestDroppableEventsPastItsBound) {
  detail::StreamState s(3);
  s.push("r1", false);
  for (int i = 0; i < 5; ++i) s.push("t" + std::to_string(i), true);
  EXPECT_EQ(s.drain(), "r1t3t4") << "the reliable event kept, the newest telemetry kept";
  EXPECT_EQ(s.dropped(), 3u);
  EXPECT_TRUE(s.drain().empty());
}

TEST(StreamState, ClosesWhenReliableEventsAloneOverflowFourTimesTheBound) {
  detail::StreamState s(2);
  int closed = 0;
  s.on_close([&] { ++closed; });
  for (int i = 0; i < 8; ++i) EXPECT_TRUE(s.push("r", false));
  EXPECT_FALSE(s.push("r", false));
  EXPECT_TRUE(s.closed());
  EXPECT_EQ(closed, 1) << "no connection behind it: the callbacks run at once";
  EXPECT_FALSE(s.push("late", true));
  int late = 0;
  s.on_close([&] { ++late; });
  EXPECT_EQ(late, 1) << "a callback added after the close runs at once";
}

TEST(StreamState, WakesTheConnectionOncePerBatch) {
  detail::StreamState s(10);
  int wakes = 0;
  s.set_wake([&] { ++wakes; });
  s.push("a", true);
  s.push("b", true);
  EXPECT_EQ(wakes, 1);
  s.drain();
  s.push("c", true);
  EXPECT_EQ(wakes, 2);
  s.close();
  EXPECT_EQ(wakes, 3) << "a close always reaches the connection";
}

using SseTest = ServerFixture;

// Routes /events to a stream handed to the test.
struct StreamCatcher {
  std::promise<EventStream> opened;
  std::future<EventStream> future = opened.get_future();
  Router router() {
    return [this](HttpRequest req, Responder res) {
      if (req.path == "/events") {
        opened.set_value(res.open_stream());
      } else {
        sample_router(std::move(req), res);
      }
    };
  }
  EventStream wait() {
    EXPECT_EQ(future.wait_for(std::chrono::seconds(10)), std::future_status::ready);
    return future.get();
  }
};

TEST_F(SseTest, EventsArriveAndTheBrowserLeavingIsNoticed) {
  StreamCatcher catcher;
  start(catcher.router());
  TestClient c(port());
  c.send(get("/events", "Accept: text/event-stream\r\n"));
  EventStream s = catcher.wait();
  std::promise<void> gone;
  s.on_close([&] { gone.set_value(); });
  std::thread sender([s] {
    s.send("telemetry", R"({"position_mm":10.5})");
    s.send("log", "line one\nline two", EventStream::Delivery::Reliable, "42");
  });
  sender.join();
  ASSERT_TRUE(c.read_until("line two\n\n"));
  const std::string& got = c.buffer();
  EXPECT_TRUE(got.starts_with("HTTP/1.1 200 OK\r\n")) << got;
  EXPECT_NE(got.find("text/event-stream"), std::string::npos);
  EXPECT_NE(got.find("\r\n\r\nevent: telemetry\ndata: {\"position_mm\":10.5}\n\n"
                     "id: 42\nevent: log\ndata: line one\ndata: line two\n\n"),
            std::string::npos)
      << got;
  EXPECT_FALSE(s.closed());
  c.close();
  ASSERT_EQ(gone.get_future().wait_for(std::chrono::seconds(10)), std::future_status::ready);
  EXPECT_TRUE(s.closed());
  EXPECT_FALSE(s.send("telemetry", "{}"));
  EXPECT_TRUE(eventually([&] { return server_->connections() == 0; }));
}

TEST_F(SseTest, ASlowBrowserLosesOldTelemetryButNeverBlocksTheSender) {
  HttpServerOptions options;
  options.stream_queue_events = 8;
  StreamCatcher catcher;
  start(catcher.router(), options);
  TestClient c(port());
  c.send(get("/events"));
  EventStream s = catcher.wait();
  // 400 events of 64 KiB: far more than the socket buffers hold while the
  // client reads nothing. send() must return each time regardless.
  const int kEvents = 400;
  const std::string payload(64 * 1024, 'p');
  for (int i = 0; i < kEvents - 1; ++i) ASSERT_TRUE(s.send("telemetry", payload));
  ASSERT_TRUE(s.send("last", "end", EventStream::Delivery::Reliable));
  EXPECT_GT(s.dropped(), 0u) << "nothing had to be dropped: the test did not fill the buffers";
  ASSERT_TRUE(c.read_until("event: last\ndata: end\n\n", std::chrono::seconds(30)));
  std::size_t delivered = 0;
  for (std::size_t at = 0; (at = c.buffer().find("event: ", at)) != std::string::npos; ++at)
    ++delivered;
  EXPECT_EQ(delivered + s.dropped(), static_cast<std::size_t>(kEvents))
      << "every event is either delivered whole or counted as dropped";
}

TEST_F(SseTest, AStreamOutlivesTheIdleTimeoutAndGetsHeartbeats) {
  HttpServerOptions options;
  options.idle_timeout = std::chrono::milliseconds(100);
  options.stream_heartbeat = std::chrono::milliseconds(50);
  StreamCatcher catcher;
  start(catcher.router(), options);
  TestClient c(port());
  // Timed from the request (the server's heartbeat timer starts after it):
  // six heartbeats 50 ms apart, well past the 100 ms idle timeout.
  const auto opened = std::chrono::steady_clock::now();
  c.send(get("/events"));
  EventStream s = catcher.wait();
  for (int i = 0; i < 6; ++i) {
    ASSERT_TRUE(c.read_until(": ping\n\n")) << "heartbeat " << i;
    c.buffer().erase(0, c.buffer().find(": ping\n\n") + 8);
  }
  EXPECT_GE(std::chrono::steady_clock::now() - opened, std::chrono::milliseconds(250));
  EXPECT_FALSE(c.closed()) << "the idle timeout does not apply to streams";
  EXPECT_FALSE(s.closed());
}

TEST_F(SseTest, CloseEndsTheStreamAfterWhatWasQueued) {
  StreamCatcher catcher;
  start(catcher.router());
  TestClient c(port());
  c.send(get("/events"));
  EventStream s = catcher.wait();
  s.send("bye", "1", EventStream::Delivery::Reliable);
  s.close();
  EXPECT_TRUE(c.wait_closed());
  EXPECT_NE(c.buffer().find("event: bye\ndata: 1\n\n"), std::string::npos);
}

TEST_F(SseTest, StopClosesStreamsAndRunsTheirCallbacks) {
  StreamCatcher catcher;
  start(catcher.router());
  TestClient c(port());
  c.send(get("/events"));
  EventStream s = catcher.wait();
  std::atomic<int> closes = 0;
  s.on_close([&] { ++closes; });
  server_->stop();
  EXPECT_TRUE(c.wait_closed());
  EXPECT_TRUE(eventually([&] { return closes.load() == 1; }));
  EXPECT_TRUE(s.closed());
}

TEST_F(SseTest, AStreamOpenedAfterTheAnswerIsClosed) {
  std::promise<EventStream> second;
  start([&](HttpRequest, Responder res) {
    res.respond(text_response(200, "answered"));
    second.set_value(res.open_stream());
  });
  TestClient c(port());
  c.send(get("/x"));
  auto r = c.read_response();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->body, "answered");
  EventStream s = second.get_future().get();
  EXPECT_TRUE(s.closed());
  EXPECT_FALSE(s.send("e", "d"));
}

TEST(Responder, CaptureHandsTheAnswerToAFunction) {
  std::optional<HttpResponse> got;
  Responder r = Responder::capture([&](HttpResponse resp) { got = std::move(resp); });
  EXPECT_TRUE(r.respond(text_response(201, "made")));
  EXPECT_FALSE(r.respond(text_response(200, "again")));
  ASSERT_TRUE(got);
  EXPECT_EQ(got->status, 201);
  EXPECT_TRUE(r.open_stream().closed());
}

}  // namespace
}  // namespace lec6::serve::testing
