#pragma once
// One accepted HTTP connection of HttpServer, and the state the listener
// shares with its connections. Every member of Connection runs on the
// connection's strand, except stop() and the posting done by its exchanges.
//
//   Reading ──request──▶ Handling ──answer──▶ Writing ──keep-alive──▶ Reading
//                           │                    └──close──▶ Lingering ─▶ Closed
//                           └──open_stream──▶ Streaming ──────────────────▶ Closed
//
// Lingering: after the last answer the send side is shut and what the client
// still sends is read and discarded for a moment, so that an early error
// answer (413 while a body is on its way) is not lost to a TCP reset.

#include <array>
#include <asio/ip/tcp.hpp>
#include <asio/steady_timer.hpp>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>

#include "http/http_codec.hpp"
#include "http/http_server.hpp"
#include "http/http_stream_state.hpp"

namespace lec6::serve::detail {

class Connection;

struct ServerShared {
  Router router;
  HttpServerOptions options;

  std::mutex mutex;
  std::unordered_map<const Connection*, std::weak_ptr<Connection>> connections;
  std::size_t counted = 0;  // served connections; refused ones linger uncounted
  bool stopping = false;

  void log(const std::string& text) const {
    if (options.log) options.log(text);
  }
};

class Connection : public std::enable_shared_from_this<Connection> {
 public:
  Connection(asio::ip::tcp::socket socket, std::shared_ptr<ServerShared> shared);
  ~Connection();

  // Serves requests, or answers `refusal` (over the connection cap) and closes.
  void start(std::optional<HttpResponse> refusal);
  // Closes now; any thread.
  void stop();
  const asio::any_io_executor& executor() const { return strand_; }
  bool counted() const { return counted_; }
  void set_counted(bool c) { counted_ = c; }

  // Posted by the exchange of request `id`.
  void answer(uint64_t id, HttpResponse response);
  void start_stream(uint64_t id, std::shared_ptr<StreamState> stream);
  // Posted by the stream's doorbell.
  void flush_stream();
  bool streams(const std::shared_ptr<StreamState>& s) const { return stream_ == s; }
  // Closed for good (any thread; answers are then dropped).
  bool closed() const { return closed_.load(); }

 private:
  enum class Phase { Reading, Handling, Writing, Streaming, Lingering, Closed };
  enum class Timeout { Idle, Linger, Heartbeat };

  void read();
  void on_read(const std::error_code& ec, std::size_t n);
  void process();
  void dispatch(HttpRequest request);
  void write(std::string bytes);
  void write_next();
  void on_written();
  void linger();
  void heartbeat();
  void arm(std::chrono::milliseconds after, Timeout what);
  void disarm();
  void close();
  void unregister();

  asio::ip::tcp::socket socket_;
  asio::any_io_executor strand_;
  asio::steady_timer timer_;
  std::shared_ptr<ServerShared> shared_;
  HttpRequestReader reader_;
  std::array<char, 8192> in_{};
  std::deque<std::string> out_;
  Phase phase_ = Phase::Reading;
  std::atomic<bool> closed_{false};
  bool reading_ = false;
  bool writing_ = false;
  bool counted_ = false;
  bool registered_ = true;
  std::chrono::steady_clock::time_point write_started_;
  uint64_t timer_generation_ = 0;
  uint64_t exchange_id_ = 0;
  std::shared_ptr<StreamState> stream_;
  // The request being answered.
  bool keep_alive_ = false;
  bool head_ = false;
  unsigned version_ = 11;
  std::string peer_;
  bool loopback_peer_ = false;
};

}  // namespace lec6::serve::detail
