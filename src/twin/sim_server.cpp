// The twin's event loop. See the header for the timing rule. (451 lines: the loop,
// its timers and its clients stay together; the saver and trace are apart.)

#include "lec6/twin/sim_server.hpp"
#include "lec6/error.hpp"
#include "lec6/transport/serial_link.hpp"

#include <poll.h>
#include <sys/eventfd.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <deque>
#include <map>
#include <stdexcept>
#include <system_error>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "lec6/client/link.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/sim/wrong_baud.hpp"
#include "twin/lumped_writer.hpp"
#include "twin/state_saver.hpp"
#include "twin/trace_mirror.hpp"

namespace lec6::twin {

namespace {

using client::LinkError;
using client::LinkErrorKind;
using transport::errno_text;
using transport::UniqueFd;

constexpr int kPtySource = 0;
constexpr int kNoSource = -1;
constexpr int kEverySource = -2;  // idle-line noise: every master hears it
constexpr int kOtherMaster = -4;  // SimServerOptions::other_master_period

timespec to_timespec(Duration d) {
  if (d < Duration::zero()) d = Duration::zero();
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(d.count() / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(d.count() % 1'000'000'000);
  return ts;
}

inline void cpu_relax() noexcept {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield");
#endif
}

void min_into(std::optional<TimePoint>& acc, std::optional<TimePoint> t) {
  if (t && (!acc || *t < *acc)) acc = t;
}

}  // namespace

struct SimServer::Impl {
  // A reply waiting for its write instant.
  struct Outgoing {
    TimePoint at;
    int owner = kNoSource;
    uint8_t id = 0;
    modbus::Bytes bytes;
  };

  struct Connection {
    UniqueFd fd;
    modbus::Bytes pending;  // what the socket could not take yet
  };

  SimServer& self;
  sim::Bus& bus;
  const SimServerOptions& options;
  SteadyClock clock;
  TimePoint origin = clock.now();
  const bool real = bus.line().timing == sim::Timing::Real;
  const Duration char_time = bus.line().line.char_time();

  // The virtual line from the masters: when its last byte has arrived.
  TimePoint line_in{};
  // Who fed the bus last; a frame the bus completes belongs to its last byte's source.
  int last_source = kNoSource;
  // Owners of the replies the bus has scheduled but not yet handed out, in order.
  std::deque<int> owners;
  uint64_t scheduled_seen = 0;
  std::deque<Outgoing> outbox;

  std::map<int, Connection> connections;
  int next_source = kPtySource + 1;
  bool pty_full_warned = false;

  std::optional<TimePoint> next_other_query;  // SimServerOptions::other_master_period
  modbus::Bytes other_query;

  std::optional<TraceMirror> mirror;  // --trace
  std::optional<LumpedWriter> tap;    // --tap
  std::optional<LumpedWriter> usb;    // --usb-latency: the master pty's replies
  bool tap_full_warned = false;
  StateSaver saver;

  std::atomic<uint64_t> bytes_in{0}, replies_sent{0}, replies_undeliverable{0}, accepted{0};
  std::atomic<int64_t> late_total_ns{0}, late_max_ns{0};

  Impl(SimServer& s, sim::Bus& b, const SimServerOptions& o)
      : self(s),
        bus(b),
        options(o),
        saver(b, {o.state_file, o.save_interval, o.state_carry, o.warn}) {
    if (options.other_master_period > Duration::zero()) {
      next_other_query = clock.now() + options.other_master_period;
      other_query = *modbus::encode_request(
          {options.other_master_id,
           modbus::ReadRegistersRequest{lec::kStateData, lec::kStateDataRegisters}});
    }
    if (options.trace) {
      mirror.emplace(bus.line().line.silent_interval(),
                     real ? modbus::FrameEnd::Silence : modbus::FrameEnd::LengthOrSilence, origin,
                     options.trace);
    }
  }

  void warn(const std::string& text) {
    if (options.warn) options.warn(text);
  }

  // The ptys exist only once the server's constructor is done.
  void open_writers() {
    if (self.tap_) tap.emplace(self.tap_->master_fd(), options.tap_latency, char_time, origin);
    if (self.pty_ && options.usb_latency > Duration::zero())
      usb.emplace(self.pty_->master_fd(), options.usb_latency, char_time, origin);
  }

  // Bytes on the line whose last bit is there at `last_byte`.
  void on_line(std::span<const uint8_t> bytes, TimePoint last_byte) {
    if (tap) tap->put(bytes, last_byte);
  }

  void flush_writers(TimePoint now) {
    if (tap && !tap->flush(now) && !tap_full_warned) {
      tap_full_warned = true;
      warn(fmt::format("{}: the tap is not being read; its bytes are dropped until it is",
                       self.tap_->client_path()));
    }
    if (usb && !usb->flush(now) && !pty_full_warned) {
      pty_full_warned = true;
      warn(fmt::format("{}: a reply could not be written; is a client reading it?",
                       self.pty_->client_path()));
    }
  }

  // Reads and discards what someone wrote to the tap: it is listen-only.
  void drain_tap() {
    std::array<uint8_t, 256> buf{};
    while (::read(self.tap_->master_fd(), buf.data(), buf.size()) > 0) {
    }
  }

  // ---- the bus -----------------------------------------------------------

  uint64_t scheduled_count() const {
    const auto& s = bus.stats();
    return s.replies - s.faults_dropped;
  }

  // Replies the bus scheduled since the last call answer frames `source` ended.
  void account(int source) {
    const uint64_t n = scheduled_count();
    for (; scheduled_seen < n; ++scheduled_seen) owners.push_back(source);
  }

  void advance(TimePoint t) {
    bus.advance(t);
    account(last_source);
    if (mirror) mirror->poll(t);
  }

  void feed(std::span<const uint8_t> bytes, TimePoint t, int source) {
    if (source != last_source) {
      // Frames that ended before these bytes belong to the previous source.
      advance(t);
      last_source = source;
    }
    bus.receive(bytes, t);
    account(source);
    if (mirror) mirror->feed(bytes, t);
  }

  // Bytes read from `source` at `t`.
  void ingest(std::span<const uint8_t> bytes, TimePoint t, int source) {
    bytes_in += bytes.size();
    if (!real) {
      feed(bytes, t, source);
      on_line(bytes, t);
      return;
    }
    // The virtual RS485 line: one character per char time from when the
    // bytes were written (≈ read), each handed over when its last bit is in.
    for (std::size_t i = 0; i < bytes.size(); ++i) {
      line_in = std::max(line_in, t) + char_time;
      feed(bytes.subspan(i, 1), line_in, source);
    }
    on_line(bytes, line_in);
  }

  void collect(TimePoint now) {
    for (sim::Reply& r : bus.take_replies(now)) {
      if (r.noise) {  // not an answer: no owner to account for
        outbox.push_back(Outgoing{real ? r.end : r.start, kEverySource, 0, std::move(r.bytes)});
        continue;
      }
      int owner = kNoSource;
      if (!owners.empty()) {
        owner = owners.front();
        owners.pop_front();
      }
      // Real timing: the whole reply at the instant its last byte would
      // have arrived (see the header). Fast: at once.
      const TimePoint at = real ? r.end : r.start;
      outbox.push_back(Outgoing{at, owner, r.id, std::move(r.bytes)});
    }
  }

  // ---- output ------------------------------------------------------------

  void flush_outbox(TimePoint now) {
    while (!outbox.empty() && outbox.front().at <= now) {
      Outgoing o = std::move(outbox.front());
      outbox.pop_front();
      on_line(o.bytes, o.at);
      if (o.owner == kEverySource) {
        spread(o.bytes);
        continue;
      }
      const bool ok = deliver(o);
      const int64_t late = (clock.now() - o.at).count();
      late_total_ns += late;
      if (late > late_max_ns) late_max_ns = late;
      if (mirror) mirror->reply(o.bytes, clock.now(), ok);
    }
  }

  // strict_baud: whether the master set its port to a rate other than the line's.
  bool master_at_wrong_baud() const {
    if (!options.strict_baud || !self.pty_) return false;
    termios t{};
    if (::tcgetattr(self.pty_->master_fd(), &t) != 0) return false;
    return cfgetospeed(&t) != transport::termios_speed(bus.line().line.baud);
  }

  // Bytes the pty's master hears (garbled when it listens at the wrong rate).
  ssize_t to_pty(const modbus::Bytes& bytes) {
    const modbus::Bytes heard = master_at_wrong_baud() ? sim::garble_wrong_baud(bytes) : bytes;
    const ssize_t n = ::write(self.pty_->master_fd(), heard.data(), heard.size());
    return n == static_cast<ssize_t>(heard.size()) ? static_cast<ssize_t>(bytes.size()) : n;
  }

  bool deliver(const Outgoing& o) {
    if (o.owner == kOtherMaster) {  // the other master's reply: every master hears it
      spread(o.bytes);
      return true;
    }
    if (o.owner == kPtySource && self.pty_ && usb) {
      // written at the adapter's tick (flush_writers), garbled at a wrong baud
      usb->put(master_at_wrong_baud() ? sim::garble_wrong_baud(o.bytes) : o.bytes, o.at);
      ++replies_sent;
      return true;
    }
    if (o.owner == kPtySource && self.pty_) {
      const ssize_t n = to_pty(o.bytes);
      if (n == static_cast<ssize_t>(o.bytes.size())) {
        ++replies_sent;
        return true;
      }
      // Nobody has read the pty for a long while (its buffer is full): the
      // line has no listener, the reply is lost, as on a real line.
      ++replies_undeliverable;
      if (!pty_full_warned) {
        pty_full_warned = true;
        warn(fmt::format("{}: a reply could not be written ({}); is a client reading it?",
                         self.pty_->client_path(),
                         n < 0 ? errno_text(errno) : std::string("short write")));
      }
      return false;
    }
    auto it = connections.find(o.owner);
    if (it == connections.end()) {
      ++replies_undeliverable;
      return false;
    }
    Connection& c = it->second;
    c.pending.insert(c.pending.end(), o.bytes.begin(), o.bytes.end());
    ++replies_sent;
    send_pending(o.owner);
    return true;
  }

  // Noise goes to every master, best effort (not traced, not counted as replies).
  void spread(const modbus::Bytes& bytes) {
    if (self.pty_ && usb) {
      usb->put(master_at_wrong_baud() ? sim::garble_wrong_baud(bytes) : bytes, clock.now());
    } else if (self.pty_) {
      [[maybe_unused]] const ssize_t n = to_pty(bytes);
    }
    for (auto& [source, c] : connections)
      c.pending.insert(c.pending.end(), bytes.begin(), bytes.end());
    for (auto it = connections.begin(); it != connections.end();) send_pending((it++)->first);
  }

  // Sends what a connection has pending; closes it on error.
  void send_pending(int source) {
    auto it = connections.find(source);
    if (it == connections.end()) return;
    Connection& c = it->second;
    while (!c.pending.empty()) {
      const ssize_t n =
          ::send(c.fd.get(), c.pending.data(), c.pending.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n > 0) {
        c.pending.erase(c.pending.begin(), c.pending.begin() + n);
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;  // POLLOUT later
      connections.erase(it);
      return;
    }
  }

  // ---- the loop --------------------------------------------------------------

  // The other master's next query, when due: on the line, and heard by every master.
  void poll_other_master(TimePoint now) {
    if (!next_other_query || *next_other_query > now) return;
    next_other_query = now + options.other_master_period;
    ingest(other_query, now, kOtherMaster);
    spread(other_query);
  }

  void step(TimePoint now) {
    poll_other_master(now);
    advance(now);
    collect(now);
    // The last moments before a reply's instant: spin, the timer would be late
    // (noise needs no such precision).
    if (!outbox.empty() && outbox.front().owner != kEverySource && outbox.front().at > now &&
        outbox.front().at - now <= options.spin_before_write) {
      const TimePoint at = outbox.front().at;
      while ((now = clock.now()) < at) cpu_relax();
    }
    flush_outbox(now);
    flush_writers(now);
    saver.check(now);
  }

  std::optional<TimePoint> deadline() const {
    std::optional<TimePoint> d = bus.next_deadline();
    if (!outbox.empty()) {
      const bool noise = outbox.front().owner == kEverySource;
      min_into(d, outbox.front().at - (noise ? Duration{} : options.spin_before_write));
    }
    min_into(d, saver.due());
    if (tap) min_into(d, tap->deadline());
    if (usb) min_into(d, usb->deadline());
    min_into(d, next_other_query);
    return d;
  }

  void read_pty() {
    std::array<uint8_t, 512> buf{};
    for (;;) {
      const ssize_t n = ::read(self.pty_->master_fd(), buf.data(), buf.size());
      if (n > 0) {
        const std::span<const uint8_t> bytes(buf.data(), static_cast<std::size_t>(n));
        const TimePoint now = clock.now();
        if (options.echo_adapter) {  // the adapter hears itself (best effort, as noise)
          [[maybe_unused]] const ssize_t e =
              ::write(self.pty_->master_fd(), buf.data(), bytes.size());
        }
        if (master_at_wrong_baud()) {
          const modbus::Bytes heard = sim::garble_wrong_baud(bytes);
          ingest(heard, now, kPtySource);
        } else {
          ingest(bytes, now, kPtySource);
        }
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
      // The Pty holds its slave open, so the master never hangs up: this is a real error.
      throw LinkError(LinkErrorKind::Io,
                      fmt::format("{}: read failed: {}", self.pty_->client_path(),
                                  n < 0 ? errno_text(errno) : "end of file"));
    }
  }

  void read_connection(int source) {
    std::array<uint8_t, 512> buf{};
    for (;;) {
      auto it = connections.find(source);
      if (it == connections.end()) return;
      const ssize_t n = ::recv(it->second.fd.get(), buf.data(), buf.size(), MSG_DONTWAIT);
      if (n > 0) {
        ingest(std::span<const uint8_t>(buf.data(), static_cast<std::size_t>(n)), clock.now(),
               source);
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
      connections.erase(it);  // closed by the client, or reset
      return;
    }
  }

  void accept_all() {
    for (;;) {
      UniqueFd fd = self.listener_->accept();
      if (!fd) return;
      connections.emplace(next_source++, Connection{std::move(fd), {}});
      ++accepted;
    }
  }

  void run() {
    // Wake at the instant asked, not up to 50 µs later (the default slack).
    ::prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
    saver.start();
    std::vector<pollfd> fds;
    std::vector<int> sources;  // per entry of fds: -2 stop, -3 listener, else a source
    constexpr int kStop = -2, kListener = -3, kTap = -4;
    open_writers();
    for (;;) {
      step(clock.now());

      fds.clear();
      sources.clear();
      fds.push_back({self.stop_fd_.get(), POLLIN, 0});
      sources.push_back(kStop);
      if (self.pty_) {
        fds.push_back({self.pty_->master_fd(), POLLIN, 0});
        sources.push_back(kPtySource);
      }
      if (self.listener_) {
        fds.push_back({self.listener_->fd(), POLLIN, 0});
        sources.push_back(kListener);
      }
      if (self.tap_) {
        fds.push_back({self.tap_->master_fd(), POLLIN, 0});
        sources.push_back(kTap);
      }
      for (const auto& [source, c] : connections) {
        const short events = static_cast<short>(POLLIN | (c.pending.empty() ? 0 : POLLOUT));
        fds.push_back({c.fd.get(), events, 0});
        sources.push_back(source);
      }

      timespec timeout{};
      const timespec* tp = nullptr;
      if (auto d = deadline()) {
        timeout = to_timespec(*d - clock.now());
        tp = &timeout;
      }
      const int r = ::ppoll(fds.data(), fds.size(), tp, nullptr);
      if (r < 0) {
        if (errno == EINTR) continue;
        throw SystemError(errno, "ppoll");
      }
      if (r == 0) continue;
      bool stop = false;
      for (std::size_t i = 0; i < fds.size(); ++i) {
        const short re = fds[i].revents;
        if (re == 0) continue;
        const int source = sources[i];
        if (source == kStop) {
          stop = true;
        } else if (source == kListener) {
          accept_all();
        } else if (source == kTap) {
          drain_tap();
        } else if (source == kPtySource) {
          if (re & (POLLIN | POLLERR | POLLHUP)) read_pty();
        } else {
          if (re & POLLOUT) send_pending(source);
          if (re & (POLLIN | POLLERR | POLLHUP)) read_connection(source);
          if (re & POLLNVAL) connections.erase(source);
        }
      }
      if (stop) break;
    }
    // Replies already due still go out; then the last save.
    step(clock.now());
    saver.final_save(clock.now());
    saver.stop();
  }
};

SimServer::SimServer(sim::Bus& bus, SimServerOptions options)
    : bus_(bus), options_(std::move(options)) {
  if (!options_.pty && !options_.tcp) {
    throw InvalidArgument("the twin needs somewhere to serve: a pty, TCP, or both");
  }
  stop_fd_.reset(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC));
  if (!stop_fd_) throw SystemError(errno, "eventfd");
  impl_ = std::make_unique<Impl>(*this, bus_, options_);
  if (options_.tcp) {
    listener_ = std::make_unique<transport::TcpListener>(options_.tcp->second, options_.tcp->first);
  }
  // Last: the symlink appears only once everything else is ready.
  if (!options_.tap_link.empty()) tap_ = std::make_unique<transport::Pty>(options_.tap_link);
  if (options_.pty) pty_ = std::make_unique<transport::Pty>(options_.pty_link);
}

SimServer::~SimServer() {
  impl_.reset();  // joins the saver
  pty_.reset();   // removes the symlink
  tap_.reset();
}

void SimServer::run() {
  impl_->run();
}

void SimServer::stop() noexcept {
  const uint64_t one = 1;
  // eventfd writes are async-signal-safe; a full counter still wakes the loop.
  [[maybe_unused]] const ssize_t n = ::write(stop_fd_.get(), &one, sizeof one);
}

std::string SimServer::endpoints() const {
  std::string out;
  if (pty_) out = pty_->client_path();
  if (listener_) {
    if (!out.empty()) out += " and ";
    out += "rtu+" + listener_->url();  // RTU frames over TCP
  }
  return out;
}

SimServer::Stats SimServer::stats() const {
  Stats s;
  s.bytes_in = impl_->bytes_in;
  s.replies_sent = impl_->replies_sent;
  s.replies_undeliverable = impl_->replies_undeliverable;
  s.connections = impl_->accepted;
  s.saves = impl_->saver.saves();
  s.save_failures = impl_->saver.failures();
  s.lateness_total = Duration(impl_->late_total_ns.load());
  s.lateness_max = Duration(impl_->late_max_ns.load());
  s.tap_bytes_dropped = impl_->tap ? impl_->tap->bytes_dropped() : 0;
  return s;
}

}  // namespace lec6::twin
