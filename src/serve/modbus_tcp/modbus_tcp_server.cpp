#include "modbus_tcp/modbus_tcp_server.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <deque>
#include <map>

#include "lec6/modbus/crc.hpp"
#include "lec6/modbus/length.hpp"
#include "lec6/modbus/mbap.hpp"

namespace lec6::serve {

using asio::ip::tcp;

// One TCP master. Lives while its socket is open or an answer is owed.
class ModbusTcpServer::Session : public std::enable_shared_from_this<Session> {
 public:
  Session(ModbusTcpServer& server, tcp::socket socket)
      : server_(server), socket_(std::move(socket)), idle_(socket_.get_executor()) {
    asio::error_code ec;
    const auto peer = socket_.remote_endpoint(ec);
    peer_ = ec ? "?" : fmt::format("{}:{}", peer.address().to_string(), peer.port());
  }

  void start() {
    arm_idle();
    read();
  }

  // lec serve is stopping: answer what is owed, then close.
  void shutdown() {
    closing_ = true;
    close_if_done();
  }

  void close() {
    if (closed_) return;
    closed_ = true;
    idle_.cancel();
    for (const auto& [key, job] : outstanding_) server_.line_.cancel(job);
    asio::error_code ec;
    socket_.shutdown(tcp::socket::shutdown_both, ec);
    socket_.close(ec);
    server_.sessions_.erase(shared_from_this());
  }

 private:
  // Requests queued on the line plus replies not yet written: what this
  // connection holds. At the limit its socket is not read (and frames already
  // read wait in the framer), so a connection holds at most that many.
  bool full() const { return outstanding_.size() + writes_.size() >= server_.limits_.max_queued; }

  // No request for idle_timeout, and nothing owed: the master is gone or
  // forgot us; close (a PLC that polls never meets it).
  void arm_idle() {
    if (server_.limits_.idle_timeout.count() <= 0) return;
    idle_.expires_after(server_.limits_.idle_timeout);
    idle_.async_wait([weak = weak_from_this()](asio::error_code ec) {
      auto self = weak.lock();
      if (ec || !self || self->closed_) return;
      if (!self->outstanding_.empty() || !self->writes_.empty()) return self->arm_idle();
      self->server_.log_(LogLevel::Info,
                         fmt::format("Modbus TCP {}: closing the connection from {}: no request "
                                     "for {:.0f} s",
                                     self->server_.url(), self->peer_,
                                     to_seconds(self->server_.limits_.idle_timeout)));
      self->close();
    });
  }

  void read() {
    if (closed_ || closing_) return;
    frames();  // those already read first (also while a read is pending)
    if (closed_ || reading_ || stalled()) return;
    reading_ = true;
    socket_.async_read_some(asio::buffer(buffer_),
                            [self = shared_from_this()](asio::error_code ec, std::size_t n) {
                              self->reading_ = false;
                              if (ec) return self->close();
                              self->arm_idle();
                              self->received(std::span(self->buffer_.data(), n));
                              self->read();
                            });
  }

  void received(std::span<const uint8_t> bytes) {
    if (server_.framing_ == Framing::Mbap) {
      mbap_.feed(bytes);
    } else {
      rtu_.insert(rtu_.end(), bytes.begin(), bytes.end());
    }
    frames();
  }

  // Frames read but not yet handed to the line (up to waiting_cap() of them,
  // stops besides). A connection keeps reading however full it is, so that a
  // stop behind any number of its other requests is seen and sent at once
  // (issue 31 rule 4): beyond the cap, a frame that is not a stop is refused
  // at once with exception 06 (server busy), a stop is taken. Only replies the
  // master does not read stop its socket being read.
  struct Waiting {
    uint16_t transaction = 0;
    uint8_t unit = 0;
    GatewayDecision decision;
  };
  std::size_t waiting_cap() const { return std::max<std::size_t>(server_.limits_.max_queued, 1); }
  bool stalled() const { return writes_.size() >= waiting_cap(); }

  void arrived(uint16_t transaction, uint8_t unit, std::span<const uint8_t> pdu) {
    GatewayDecision d = decide(server_.policy_, unit, pdu);
    if (waiting_.size() - stops_waiting() < waiting_cap() || is_stop(d) ||
        std::holds_alternative<LocalAnswer>(d)) {
      waiting_.push_back({transaction, unit, std::move(d)});
      return;
    }
    // Over the cap: answered at once (MBAP matches it by its transaction id;
    // an RTU master hears nothing, as from a controller that is busy).
    if (!refusing_) {
      refusing_ = true;
      server_.log_(LogLevel::Warning,
                   fmt::format("Modbus TCP {}: {} sent more than {} requests ahead of their "
                               "answers: the rest are refused with exception 06 (server busy) "
                               "until answers go out; stops are still taken",
                               server_.url(), peer_, 2 * waiting_cap()));
    }
    const uint8_t raw = pdu.empty() ? 0 : pdu[0];
    const auto fc = static_cast<modbus::FunctionCode>(raw & 0x7F);
    answer(transaction, unit,
           modbus::ExceptionResponse{fc, raw, modbus::ExceptionCode::ServerBusy});
  }

  std::size_t stops_waiting() const {
    std::size_t n = 0;
    for (const Waiting& w : waiting_) n += is_stop(w.decision) ? 1 : 0;
    return n;
  }

  static bool is_stop(const GatewayDecision& d) {
    const auto* r = std::get_if<LineRequest>(&d);
    return r && r->priority == Priority::Emergency;
  }

  // Stops go to the line whatever this connection holds; the rest in order,
  // while it has room (see full()).
  void dispatch() {
    // Up to the last stop waiting, every frame goes now, in the order sent
    // (a stop must not overtake this master's earlier writes; the scheduler
    // keeps them in order on the line).
    std::size_t last_stop = 0;
    for (std::size_t i = 0; i < waiting_.size(); ++i)
      if (is_stop(waiting_[i].decision)) last_stop = i + 1;
    for (; last_stop > 0 && !closed_; --last_stop) {
      Waiting w = std::move(waiting_.front());
      waiting_.pop_front();
      handle(w.transaction, w.unit, w.decision);
    }
    while (!waiting_.empty() && !full() && !closed_) {
      Waiting w = std::move(waiting_.front());
      waiting_.pop_front();
      handle(w.transaction, w.unit, w.decision);
    }
    if (waiting_.empty()) refusing_ = false;
  }

  // Handles the frames read.
  void frames() {
    if (closed_) return;
    if (server_.framing_ == Framing::Mbap) {
      for (;;) {
        auto adu = mbap_.next();
        if (!adu) break;
        arrived(adu->header.transaction, adu->header.unit, adu->pdu);
        dispatch();  // to the line while it has room, before the next frame is judged
      }
      dispatch();
      if (mbap_.status() == modbus::MbapFramer::Status::Broken) {
        server_.log_(LogLevel::Warning,
                     fmt::format("Modbus TCP {}: closing the connection from {}: {}", server_.url(),
                                 peer_, mbap_.error()));
        close();
      }
      return;
    }
    rtu_frames();
    dispatch();
  }

  // RTU over TCP: a frame completes on the length its function implies. A
  // frame that fails its CRC is dropped with whatever follows it in the
  // buffer, as a controller drops a frame it cannot read; a frame of an
  // unknown function is all that arrived (devices servers send a frame per
  // segment) and gets exception 01 if its CRC holds.
  void rtu_frames() {
    while (rtu_.size() >= 4) {
      auto length = modbus::request_length(rtu_);
      // FC06 (one register), which the controller's own codec does not size
      // (it refuses FC06) but the gateway takes: always 8 bytes. Unsized, one
      // split across segments or pipelined with a stop was dropped with it.
      if (rtu_[1] == 0x06) length = {modbus::FrameLength::Status::Known, 8};
      std::size_t size = rtu_.size();
      if (length.status == modbus::FrameLength::Status::NeedMore) return;
      if (length.status == modbus::FrameLength::Status::Known) {
        if (rtu_.size() < length.bytes) return;
        size = length.bytes;
      }
      const std::span<const uint8_t> frame(rtu_.data(), size);
      if (size > modbus::kMaxAdu || !modbus::crc_ok(frame)) {
        rtu_.clear();
        return;
      }
      const uint8_t unit = frame[0];
      arrived(0, unit, frame.subspan(1, size - 3));
      rtu_.erase(rtu_.begin(), rtu_.begin() + static_cast<std::ptrdiff_t>(size));
      dispatch();
    }
  }

  void handle(uint16_t transaction, uint8_t unit, const GatewayDecision& decision) {
    if (const auto* local = std::get_if<LocalAnswer>(&decision))
      return answer(transaction, unit, local->pdu);
    const auto& request = std::get<LineRequest>(decision);
    const uint64_t key = next_key_++;
    Job job;
    job.priority = request.priority;
    job.source = source_;
    job.frame = request.frame;
    job.max_cache_age = request.max_cache_age;
    job.not_before = seen_[unit];
    job.attempts = request.attempts;
    std::weak_ptr<Session> weak = weak_from_this();
    auto& io = server_.io_;
    job.done = [weak, &io, key, transaction, request](const JobResult& r) {
      asio::post(io, [weak, key, transaction, request, r] {
        if (auto self = weak.lock()) self->finished(key, transaction, request, r);
      });
    };
    outstanding_[key] = 0;  // before submit: a cache hit answers at once (posted)
    outstanding_[key] = server_.line_.submit(std::move(job));
  }

  void finished(uint64_t key, uint16_t transaction, const LineRequest& request,
                const JobResult& r) {
    const modbus::RequestFrame& frame = request.frame;
    outstanding_.erase(key);
    if (closed_) return;
    if (r.failure == Failure::None) seen_[frame.id] = std::max(seen_[frame.id], r.started);
    if (auto reply = tcp_reply_pdu(request, r)) answer_pdu(transaction, frame.id, *reply);
    close_if_done();
    read();  // a slot came free
  }

  void close_if_done() {
    if (closing_ && outstanding_.empty() && writes_.empty()) close();
  }

  void answer(uint16_t transaction, uint8_t unit, const modbus::Response& pdu) {
    if (server_.framing_ == Framing::Rtu) {
      // A line has no gateway exceptions: the master hears nothing, as it
      // would from a controller that is not there. Broadcasts get no reply.
      const auto* ex = std::get_if<modbus::ExceptionResponse>(&pdu);
      if (unit == modbus::kBroadcastId ||
          (ex && !modbus::is_controller_exception(static_cast<uint8_t>(ex->code)))) {
        return;
      }
      send(modbus::encode_response({unit, pdu}));
      return;
    }
    send(modbus::encode_mbap(transaction, unit, modbus::encode_response_pdu(pdu)));
  }

  // An encoded reply PDU (FC06's echo is not in our codec: gateway.hpp).
  void answer_pdu(uint16_t transaction, uint8_t unit, const modbus::Bytes& pdu) {
    if (server_.framing_ == Framing::Rtu) {
      const bool exception = pdu.size() >= 2 && (pdu[0] & 0x80) != 0;
      if (unit == modbus::kBroadcastId || (exception && !modbus::is_controller_exception(pdu[1])))
        return;
      // Sized at once: GCC 12 at -O2 takes an insert after a 1-byte
      // initialiser for an out-of-bounds copy (-Warray-bounds).
      modbus::Bytes adu(pdu.size() + 1);
      adu[0] = unit;
      std::copy(pdu.begin(), pdu.end(), adu.begin() + 1);
      modbus::append_crc(adu);
      send(std::move(adu));
      return;
    }
    send(modbus::encode_mbap(transaction, unit, pdu));
  }

  void send(modbus::Bytes bytes) {
    writes_.push_back(std::move(bytes));
    if (writes_.size() == 1) write_next();
  }

  void write_next() {
    if (closed_ || writes_.empty()) return;
    asio::async_write(socket_, asio::buffer(writes_.front()),
                      [self = shared_from_this()](asio::error_code ec, std::size_t) {
                        if (ec) return self->close();
                        self->writes_.pop_front();
                        self->write_next();
                        self->close_if_done();
                        self->read();  // room again for a master that was not reading replies
                      });
  }

  ModbusTcpServer& server_;
  tcp::socket socket_;
  std::string peer_;
  std::array<uint8_t, 1024> buffer_{};
  modbus::MbapFramer mbap_;
  modbus::Bytes rtu_;
  std::deque<modbus::Bytes> writes_;
  std::deque<Waiting> waiting_;
  std::map<uint64_t, JobId> outstanding_;
  std::map<uint8_t, TimePoint> seen_;  // per unit: the newest data this master was shown
  uint64_t next_key_ = 1;
  // This connection's commands take turns with other clients' (command_turns.hpp).
  const JobSource source_ = new_job_source();
  asio::steady_timer idle_;
  bool reading_ = false;
  bool closing_ = false;
  bool closed_ = false;
  bool refusing_ = false;  // over the cap since the last time it drained (logged once)
};

ModbusTcpServer::ModbusTcpServer(asio::io_context& io, const ListenerConfig& config,
                                 Framing framing, Line& line, GatewayPolicy policy, Log log,
                                 ModbusTcpLimits limits)
    : io_(io),
      acceptor_(io),
      retry_(io),
      limits_(limits),
      framing_(framing),
      line_(line),
      policy_(std::move(policy)),
      log_(std::move(log)),
      address_(config.listen.address) {
  policy_.read_only = policy_.read_only || config.read_only;
  const tcp::endpoint at(asio::ip::make_address(config.listen.address), config.listen.port);
  acceptor_.open(at.protocol());
  acceptor_.set_option(tcp::acceptor::reuse_address(true));
  acceptor_.bind(at);
  acceptor_.listen();
  port_ = acceptor_.local_endpoint().port();
  if (!config.listen.loopback()) {
    log_(LogLevel::Warning, fmt::format("{} listens on {}: reachable from other machines{}", url(),
                                        config.listen.text(),
                                        policy_.read_only ? " (read-only)" : ", writes included"));
  }
  accept();
}

ModbusTcpServer::~ModbusTcpServer() {
  stop();
}

std::string ModbusTcpServer::url() const {
  const bool v6 = address_.find(':') != std::string::npos;
  return fmt::format("{}://{}{}{}:{}", framing_ == Framing::Mbap ? "tcp" : "rtu+tcp", v6 ? "[" : "",
                     address_, v6 ? "]" : "", port_);
}

void ModbusTcpServer::accept() {
  acceptor_.async_accept([this](asio::error_code ec, tcp::socket socket) {
    if (stopped_ || ec == asio::error::operation_aborted) return;
    if (ec) {
      // Out of file descriptors and the like: try again shortly, not in a spin.
      log_(LogLevel::Warning, fmt::format("Modbus TCP {}: accept failed: {}; retrying in 100 ms",
                                          url(), ec.message()));
      retry_.expires_after(std::chrono::milliseconds(100));
      retry_.async_wait([this](asio::error_code e) {
        if (!e && !stopped_) accept();
      });
      return;
    }
    if (sessions_.size() >= limits_.max_connections) {
      refuse(std::move(socket));
    } else {
      socket.set_option(tcp::no_delay(true), ec);
      auto session = std::make_shared<Session>(*this, std::move(socket));
      sessions_.insert(session);
      session->start();
    }
    accept();
  });
}

// Over the connection cap: closed at once, with a log line (at most one a
// second, so a flood of connections does not flood the log).
void ModbusTcpServer::refuse(tcp::socket socket) {
  ++refused_;
  const auto now = std::chrono::steady_clock::now();
  if (now - last_refusal_log_ >= std::chrono::seconds(1)) {
    last_refusal_log_ = now;
    asio::error_code ec;
    const auto peer = socket.remote_endpoint(ec);
    log_(LogLevel::Warning,
         fmt::format("Modbus TCP {}: refused the connection from {}: {} connections open (at most "
                     "{}); {} refused so far",
                     url(), ec ? "?" : peer.address().to_string(), sessions_.size(),
                     limits_.max_connections, refused_));
  }
  asio::error_code ec;
  socket.close(ec);
}

void ModbusTcpServer::shutdown() {
  stopped_ = true;
  asio::error_code ec;
  acceptor_.close(ec);
  retry_.cancel();
  const auto sessions = sessions_;
  for (const auto& s : sessions) s->shutdown();
}

void ModbusTcpServer::stop() {
  shutdown();
  const auto sessions = sessions_;
  for (const auto& s : sessions) s->close();
}

}  // namespace lec6::serve
