// One HTTP connection: read a request, hand it to the router, write the
// answer (or keep an event stream open), and again.
//
// Why not Beast's own stream and http::async_read/async_write (issue 28):
// the bytes are parsed by Beast's request_parser already, and serialised by
// Beast (http_codec.cpp, http_encode.cpp); only the feeding is ours, and it
// has to be.
//   - http::async_read reads into a buffer and puts whatever the socket gave
//     into the parser, cut as the network cut it; the parser's put is not
//     virtual and its hooks (body reader, on_chunk_*) run after a piece is
//     parsed, so there is no place between read and put. Beast's answer then
//     depends on the cuts, and each of these was a fuzz finding (kept in
//     tests/fuzz_regressions/http/): the start line parsed on the first put
//     and not again until the header is whole, the header limit counted from
//     the last put (http-505-or-cut-short, header-over-small-limit,
//     oversized-and-malformed-header); header and chunked body in one put,
//     trailer fields merged into the header before it is checked
//     (host-only-in-a-chunked-trailer, header-checked-before-a-failing-body);
//     a chunk's size taken off the body limit again on every retry while an
//     extension waits for bytes (http-crash-90d75756). HttpRequestReader
//     gives the parser a whole header, then whole chunk lines, then chunk
//     data, so the same bytes get the same answer however they arrive; the
//     fuzz harness checks exactly that reader, which async_read would bypass.
//   - beast::tcp_stream and http::async_write need Boost.Asio; the daemon's
//     one io_context is standalone Asio, shared by Modbus TCP, MQTT, HTTP,
//     the stats timer and signals, and is in the public header
//     lec6/serve/daemon.hpp: 14 files, ~100 asio:: uses, the error_code type
//     of every handler, `lec history`, the tests and the package list. For
//     what it would buy: tcp_stream's timeout is per operation and closes
//     the socket; ours are not (one idle deadline for a whole request read
//     and for a response write, a heartbeat and write-stall check on
//     streams, a 2 s lingering close), so the timer here would stay; an
//     event stream is not a message (a head, then bytes until close), so its
//     writes would stay raw writes too.

#include "http/http_connection.hpp"

#include <fmt/format.h>

#include <asio/post.hpp>
#include <asio/write.hpp>

namespace lec6::serve::detail {

namespace {

constexpr std::chrono::milliseconds kLinger{2000};

// A Responder's exchange with a live connection: answers are posted to the
// connection's strand, whatever thread gives them. It owns the connection
// while the request waits for its answer (nothing else does then: no read,
// no timer is pending).
class ConnectionExchange final : public Exchange {
 public:
  ConnectionExchange(std::shared_ptr<Connection> c, asio::any_io_executor strand, uint64_t id,
                     std::size_t stream_limit)
      : conn_(std::move(c)), strand_(std::move(strand)), id_(id), stream_limit_(stream_limit) {}

  // A handler that let go of every copy of its Responder without answering.
  ~ConnectionExchange() override {
    if (claim()) post_answer(error_response(500, "internal error: the request was not answered"));
  }

  bool respond(HttpResponse response) override {
    return claim() && post_answer(std::move(response));
  }

  EventStream open_stream() override {
    if (!claim() || conn_->closed()) return {};
    auto s = std::make_shared<StreamState>(stream_limit_);
    // The doorbell: flush on the connection's strand; a stream whose
    // connection is gone still gets its close callbacks.
    s->set_wake([wc = std::weak_ptr<Connection>(conn_), ws = std::weak_ptr<StreamState>(s),
                 strand = strand_] {
      asio::post(strand, [wc, ws] {
        auto s = ws.lock();
        if (!s) return;
        auto c = wc.lock();
        if (c && c->streams(s)) {
          c->flush_stream();
        } else if (s->closed()) {
          s->run_close_callbacks();
        }
      });
    });
    asio::post(strand_, [c = conn_, id = id_, s] { c->start_stream(id, s); });
    return stream_of(std::move(s));
  }

  static Responder make(std::shared_ptr<ConnectionExchange> e) {
    return responder_of(std::move(e));
  }

 private:
  bool post_answer(HttpResponse response) {
    if (conn_->closed()) return false;
    asio::post(strand_, [c = conn_, id = id_, r = std::move(response)]() mutable {
      c->answer(id, std::move(r));
    });
    return true;
  }

  std::shared_ptr<Connection> conn_;
  asio::any_io_executor strand_;
  uint64_t id_;
  std::size_t stream_limit_;
};

std::string endpoint_text(const asio::ip::tcp::endpoint& e) {
  const auto a = e.address();
  return a.is_v6() ? fmt::format("[{}]:{}", a.to_string(), e.port())
                   : fmt::format("{}:{}", a.to_string(), e.port());
}

}  // namespace

Connection::Connection(asio::ip::tcp::socket socket, std::shared_ptr<ServerShared> shared)
    : socket_(std::move(socket)),
      strand_(socket_.get_executor()),
      timer_(strand_),
      shared_(std::move(shared)),
      reader_(shared_->options.limits) {
  std::error_code ec;
  const auto peer = socket_.remote_endpoint(ec);
  if (!ec) {
    peer_ = endpoint_text(peer);
    const auto a = peer.address();
    loopback_peer_ = a.is_loopback() ||
                     (a.is_v6() && a.to_v6().is_v4_mapped() && a.to_v6().to_v4().is_loopback());
  }
}

Connection::~Connection() {
  if (stream_) {
    stream_->close();
    stream_->run_close_callbacks();
  }
  unregister();
}

void Connection::start(std::optional<HttpResponse> refusal) {
  if (refusal) {
    phase_ = Phase::Writing;
    keep_alive_ = false;
    write(encode_response(*refusal, {.keep_alive = false}));
    return;
  }
  arm(shared_->options.idle_timeout, Timeout::Idle);
  read();
}

void Connection::stop() {
  asio::post(strand_, [self = shared_from_this()] { self->close(); });
}

void Connection::read() {
  if (reading_ || phase_ == Phase::Closed) return;
  reading_ = true;
  socket_.async_read_some(asio::buffer(in_),
                          [self = shared_from_this()](const std::error_code& ec, std::size_t n) {
                            self->on_read(ec, n);
                          });
}

void Connection::on_read(const std::error_code& ec, std::size_t n) {
  reading_ = false;
  if (phase_ == Phase::Closed) return;
  if (ec) {
    // The client went away (or closed its side after a request: nothing to
    // answer on a half-open connection that sent no complete request).
    close();
    return;
  }
  if (phase_ != Phase::Reading) {
    read();  // a stream or a lingering close: what arrives is discarded
    return;
  }
  reader_.feed(std::string_view(in_.data(), n));
  process();
}

void Connection::process() {
  if (reader_.take_expect_continue()) write(std::string(kContinue));
  switch (reader_.status()) {
    case HttpRequestReader::Status::NeedMore:
      read();
      break;
    case HttpRequestReader::Status::Complete:
      dispatch(reader_.take());
      break;
    case HttpRequestReader::Status::Error: {
      const auto& e = reader_.error();
      phase_ = Phase::Writing;
      keep_alive_ = false;
      write(encode_response(error_response(e.status, e.reason), {.keep_alive = false}));
      break;
    }
  }
}

void Connection::dispatch(HttpRequest request) {
  phase_ = Phase::Handling;
  disarm();  // a handler may take its time; the client waits for it
  head_ = request.method == "HEAD";
  version_ = request.version;
  keep_alive_ = request.keep_alive;
  request.peer = peer_;
  request.loopback_peer = loopback_peer_;
  Responder responder = ConnectionExchange::make(std::make_shared<ConnectionExchange>(
      shared_from_this(), strand_, ++exchange_id_, shared_->options.stream_queue_events));
  if (!shared_->router) {
    responder.respond(error_response(404, "no such endpoint: " + request.path));
    return;
  }
  const std::string what = request.method + " " + request.path;
  try {
    shared_->router(std::move(request), responder);
  } catch (const std::exception& e) {
    shared_->log(fmt::format("HTTP {}: the handler failed: {}", what, e.what()));
    responder.respond(error_response(500, std::string("internal error: ") + e.what()));
  }
}

void Connection::answer(uint64_t id, HttpResponse response) {
  if (phase_ != Phase::Handling || id != exchange_id_) return;
  {
    std::lock_guard lock(shared_->mutex);
    if (shared_->stopping) keep_alive_ = false;
  }
  phase_ = Phase::Writing;
  arm(shared_->options.idle_timeout, Timeout::Idle);  // a client that does not read
  write(encode_response(response, {.keep_alive = keep_alive_, .head = head_, .version = version_}));
}

void Connection::start_stream(uint64_t id, std::shared_ptr<StreamState> stream) {
  if (phase_ != Phase::Handling || id != exchange_id_) {
    stream->close();  // its doorbell finds no connection: callbacks run
    return;
  }
  phase_ = Phase::Streaming;
  stream_ = std::move(stream);
  write(encode_event_stream_head());
  arm(shared_->options.stream_heartbeat, Timeout::Heartbeat);
  read();  // only to notice the browser leaving
  flush_stream();
}

void Connection::flush_stream() {
  if (phase_ != Phase::Streaming || writing_) return;
  std::string bytes = stream_->drain();
  if (!bytes.empty()) {
    write(std::move(bytes));
  } else if (stream_->closed()) {
    close();  // closed, and everything queued before was written
  }
}

void Connection::write(std::string bytes) {
  out_.push_back(std::move(bytes));
  if (!writing_) write_next();
}

void Connection::write_next() {
  if (phase_ == Phase::Closed) return;
  if (out_.empty()) {
    writing_ = false;
    on_written();
    return;
  }
  writing_ = true;
  write_started_ = std::chrono::steady_clock::now();
  asio::async_write(socket_, asio::buffer(out_.front()),
                    [self = shared_from_this()](const std::error_code& ec, std::size_t) {
                      if (self->phase_ == Phase::Closed) return;
                      if (ec) {
                        self->close();
                        return;
                      }
                      self->out_.pop_front();
                      self->write_next();
                    });
}

void Connection::on_written() {
  switch (phase_) {
    case Phase::Writing:
      if (!keep_alive_) {
        linger();
        return;
      }
      phase_ = Phase::Reading;
      arm(shared_->options.idle_timeout, Timeout::Idle);
      reader_.feed({});  // a pipelined request may be buffered already
      process();
      return;
    case Phase::Streaming:
      flush_stream();
      return;
    default:
      return;  // 100 Continue went out while reading
  }
}

void Connection::linger() {
  phase_ = Phase::Lingering;
  std::error_code ec;
  socket_.shutdown(asio::ip::tcp::socket::shutdown_send, ec);
  arm(std::min(kLinger, shared_->options.idle_timeout), Timeout::Linger);
  read();
}

void Connection::heartbeat() {
  if (phase_ != Phase::Streaming) return;
  if (writing_ &&
      std::chrono::steady_clock::now() - write_started_ > shared_->options.idle_timeout) {
    close();  // the browser stopped reading: not our problem to buffer for
    return;
  }
  if (!writing_) write(encode_event_comment("ping"));
  arm(shared_->options.stream_heartbeat, Timeout::Heartbeat);
}

void Connection::arm(std::chrono::milliseconds after, Timeout what) {
  const uint64_t generation = ++timer_generation_;
  timer_.expires_after(after);
  timer_.async_wait([self = shared_from_this(), generation, what](const std::error_code& ec) {
    if (ec || generation != self->timer_generation_ || self->phase_ == Phase::Closed) return;
    if (what == Timeout::Heartbeat) {
      self->heartbeat();
    } else {
      self->close();
    }
  });
}

void Connection::disarm() {
  ++timer_generation_;
  timer_.cancel();
}

void Connection::close() {
  if (phase_ == Phase::Closed) return;
  phase_ = Phase::Closed;
  closed_ = true;
  unregister();  // before the client can see the close: connections() agrees with it
  disarm();
  std::error_code ec;
  socket_.shutdown(asio::ip::tcp::socket::shutdown_both, ec);
  socket_.close(ec);
  out_.clear();
  if (stream_) {
    stream_->close();
    stream_->run_close_callbacks();
  }
}

void Connection::unregister() {
  std::lock_guard lock(shared_->mutex);
  if (!registered_) return;
  registered_ = false;
  shared_->connections.erase(this);
  if (counted_) --shared_->counted;
}

}  // namespace lec6::serve::detail
