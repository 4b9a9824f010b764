#pragma once
// The HTTP listener of `lec serve`: standalone Asio sockets, the sans-I/O
// codec of http_codec.hpp, and a Router that the API plugs in. One request at
// a time per connection (keep-alive, pipelining answered in order), an idle
// timeout, a cap on connections, and Server-Sent Events for the dashboard.
//
// A router gets each request with a Responder and answers exactly once, now
// or later, from any thread:
//
//   Router router = [&](HttpRequest req, Responder res) {
//     if (req.path == "/api/version")                       // sync reply
//       return res.respond(json_response(200, {{"version", "0.1.0"}}));
//     if (req.path == "/api/slow") {                        // async reply
//       line.submit(job, [res](Result r) { res.respond(json_response(200, to_json(r))); });
//       return;
//     }
//     if (req.path == "/api/events") {                      // SSE stream
//       EventStream s = res.open_stream();
//       hub.add(s);                   // later, any thread: s.send("telemetry", json.dump());
//       s.on_close([&hub, s] { hub.remove(s); });
//       return;
//     }
//     res.respond(error_response(404, "no such endpoint: " + req.path));
//   };
//
// A Responder dropped without an answer answers 500; a router that throws
// answers 500 with the exception's message. The router runs on the server's
// thread: it must not block (submit work, answer from the completion).
//
// Thread safety: HttpServer's members may be called from any thread;
// Responder and EventStream are cheap copyable handles usable from any thread.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "http/http.hpp"
#include "http/http_codec.hpp"
#include "lec6/serve/config.hpp"

namespace asio {
class io_context;
}

namespace lec6::serve {

namespace detail {
class Exchange;
class StreamState;
}  // namespace detail

// One Server-Sent Events stream (text/event-stream) to a browser. Sending
// never blocks: events wait in a bounded queue; when a slow browser lets it
// grow past `stream_queue_events`, the oldest droppable event goes (telemetry
// is superseded by the next sample anyway). Reliable events are never dropped;
// if they alone overflow four times the bound, the stream is closed (the
// browser's EventSource reconnects and starts afresh).
class EventStream {
 public:
  enum class Delivery { Droppable, Reliable };

  EventStream() = default;  // a stream that is already closed

  // Queues one event; false when the stream is closed.
  bool send(std::string_view event, std::string_view data, Delivery delivery = Delivery::Droppable,
            std::optional<std::string_view> id = std::nullopt) const;
  bool closed() const;
  // Ends the stream (after the events already queued).
  void close() const;
  // Runs once when the stream ends, whoever ended it (browser gone, close(),
  // stop(), overflow): on the server's thread, or at once if already closed.
  void on_close(std::function<void()> callback) const;
  std::size_t dropped() const;  // droppable events dropped so far

  bool operator==(const EventStream& o) const { return state_ == o.state_; }

 private:
  friend class detail::Exchange;
  explicit EventStream(std::shared_ptr<detail::StreamState> s) : state_(std::move(s)) {}
  std::shared_ptr<detail::StreamState> state_;
};

class Responder {
 public:
  // The answer; false if the request was answered already or its connection
  // has gone (the response is then dropped).
  bool respond(HttpResponse response) const;
  // Answers with an open text/event-stream; a closed stream if the request was
  // answered already or its connection has gone.
  EventStream open_stream() const;
  bool answered() const;

  // For testing handlers without a socket: the response goes to `sink` (on
  // the caller's thread); open_stream() gives a closed stream.
  static Responder capture(std::function<void(HttpResponse)> sink);

 private:
  friend class detail::Exchange;
  explicit Responder(std::shared_ptr<detail::Exchange> e) : exchange_(std::move(e)) {}
  std::shared_ptr<detail::Exchange> exchange_;
};

using Router = std::function<void(HttpRequest, Responder)>;

struct HttpServerOptions {
  std::chrono::milliseconds idle_timeout{60000};      // waiting for a request, or a stalled write
  std::size_t max_connections = 256;                  // more: 503 and close
  std::size_t stream_queue_events = 256;              // per stream, then drop the oldest
  std::chrono::milliseconds stream_heartbeat{15000};  // ": ping" on open streams
  HttpLimits limits;
  std::function<void(std::string)> log;  // warnings and handler failures; may be empty
};

class HttpServer {
 public:
  // Binds and listens at once (throws std::runtime_error naming the address
  // when it cannot); serves while `io` runs. Port 0: a free port, see port().
  // A listener that is not loopback is logged as a warning.
  HttpServer(asio::io_context& io, const ListenerConfig& config, Router router,
             HttpServerOptions options = {});
  ~HttpServer();  // stop()
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  uint16_t port() const;
  std::string address() const;  // "127.0.0.1:8080", as bound
  // Stops accepting and closes every connection and stream (SIGTERM); answers
  // still to come are dropped. Returns at once; the closing happens on `io`.
  void stop();
  std::size_t connections() const;  // open now, streams included

 private:
  struct Core;
  std::shared_ptr<Core> core_;
};

}  // namespace lec6::serve
