// The in-process RS485 line with lec sim's faults (see the header).

#include "lec6/twin/virtual_line.hpp"

#include <algorithm>
#include <cstring>
#include <deque>
#include <map>
#include <optional>
#include <string>

#include "lec6/lec/memory_map.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/sim/usb_latency.hpp"
#include "lec6/sim/wrong_baud.hpp"

namespace lec6::twin {

namespace {

// As transport::SerialOptions::echo_timeout: how long, beyond its wire time, the echo may take.
constexpr Duration kVirtualEchoTimeout = std::chrono::milliseconds(50);

void earliest_into(std::optional<TimePoint>& acc, std::optional<TimePoint> t) {
  if (t && (!acc || *t < *acc)) acc = t;
}

}  // namespace

struct VirtualLine::State {
  sim::Bus& bus;
  VirtualClock& clock;
  const VirtualLineOptions options;
  const bool real = bus.line().timing == sim::Timing::Real;

  uint32_t baud = bus.line().line.baud;  // the master's port (the last one opened)
  bool port_open = false;
  // The bus has run to here: ahead of the clock while a query is still on its way in.
  TimePoint bus_time = clock.now();
  TimePoint line_in{};                  // the last byte any master put on the line arrives
  std::optional<TimePoint> next_other;  // the other master's next query starts
  modbus::Bytes other_query;
  // What the master's port will hear, by the instant each piece's last bit is in.
  std::multimap<TimePoint, modbus::Bytes> on_line;
  sim::UsbLatency adapter{options.usb_latency, sim::UsbLatency::kFtdiPacketBytes, clock.now()};
  std::deque<modbus::Bytes> inbox;  // handed over: there to read

  State(sim::Bus& b, VirtualClock& c, VirtualLineOptions o) : bus(b), clock(c), options(o) {
    if (options.other_master_period > Duration::zero()) {
      next_other = clock.now() + options.other_master_period;
      other_query = *modbus::encode_request(
          {options.other_master_id,
           modbus::ReadRegistersRequest{lec::kStateData, lec::kStateDataRegisters}});
    }
    bus.advance(bus_time);  // the line is live from now (its noise, say)
  }

  // Fast timing takes no wire time (as SimLink and the bus).
  Duration wire(std::size_t bytes, uint32_t at_baud) const {
    if (!real) return Duration::zero();
    return modbus::LineTiming{.baud = at_baud}.wire_time(bytes);
  }
  Duration bus_wire(std::size_t bytes) const { return wire(bytes, bus.line().line.baud); }
  bool wrong_baud() const { return baud != bus.line().line.baud; }

  // Bytes for the master's port whose last bit is in at `last_byte`, one
  // character per `char_time` before it (the adapter lumps them byte by byte).
  // `own`: its echo, which its UART hears at its own rate.
  void hear(std::span<const uint8_t> bytes, TimePoint last_byte, Duration char_time, bool own) {
    modbus::Bytes heard = !own && wrong_baud() ? sim::garble_wrong_baud(bytes)
                                               : modbus::Bytes(bytes.begin(), bytes.end());
    if (heard.empty()) return;
    if (options.usb_latency <= Duration::zero()) {
      on_line.emplace(last_byte, std::move(heard));
      return;
    }
    const auto n = static_cast<int64_t>(heard.size());
    for (int64_t i = 0; i < n; ++i)
      on_line.emplace(last_byte - char_time * (n - 1 - i),
                      modbus::Bytes{heard[static_cast<std::size_t>(i)]});
  }

  // Whatever the bus has put on the line by bus_time (replies, noise): the master hears it all.
  void collect() {
    for (sim::Reply& r : bus.take_replies(bus_time))
      hear(r.bytes, real ? r.end : r.start, bus_wire(1), false);
  }

  // Bytes on the bus from a master, their last one in no sooner than `arrival`.
  // Returns when it is in.
  // Byte by byte, one character apart (as lec sim's event loop feeds its
  // bus): two masters' queries back to back are one bad frame to the
  // controllers, as on a real line, and a query split by a gap is seen with
  // that gap (the Silent INT probe), not the whole chunk's wire time more.
  TimePoint feed(std::span<const uint8_t> bytes, TimePoint arrival) {
    arrival = std::max({arrival, line_in + bus_wire(bytes.size()), bus_time});
    line_in = arrival;
    const auto n = static_cast<int64_t>(bytes.size());
    for (int64_t i = 0; i < n; ++i) {
      // Never before what the bus has already seen (a master at a faster
      // wrong baud: its bytes are fewer and would start earlier).
      const TimePoint at = std::max(bus_time, arrival - bus_wire(1) * (n - 1 - i));
      bus.receive(bytes.subspan(static_cast<std::size_t>(i), 1), at);
      bus_time = at;
    }
    bus_time = std::max(bus_time, arrival);
    collect();
    return arrival;
  }

  // The line up to `t`: the other master's queries due by then, the bus, and
  // what the adapter hands over by then.
  void catch_up(TimePoint t) {
    while (next_other && *next_other <= t) {
      const TimePoint start = *next_other;
      *next_other += options.other_master_period;
      const TimePoint in = feed(other_query, start + bus_wire(other_query.size()));
      hear(other_query, in, bus_wire(1), false);
    }
    if (t > bus_time) {
      bus.advance(t);
      bus_time = t;
    }
    collect();
    while (!on_line.empty() && on_line.begin()->first <= t) {
      auto node = on_line.extract(on_line.begin());
      adapter.push(node.mapped(), node.key());
    }
    for (auto& d : adapter.take(t)) inbox.push_back(std::move(d.bytes));
  }

  // The next instant anything happens on the line (after catch_up(now): later than now).
  std::optional<TimePoint> next_event() const {
    std::optional<TimePoint> d = bus.next_deadline();
    earliest_into(d, next_other);
    if (!on_line.empty()) earliest_into(d, on_line.begin()->first);
    earliest_into(d, adapter.next_delivery());
    return d;
  }

  std::size_t take_into(std::span<uint8_t> buffer) {
    modbus::Bytes& next = inbox.front();
    const std::size_t n = std::min(buffer.size(), next.size());
    std::memcpy(buffer.data(), next.data(), n);
    next.erase(next.begin(), next.begin() + static_cast<std::ptrdiff_t>(n));
    if (next.empty()) inbox.pop_front();
    return n;
  }
};

class VirtualLine::Port final : public client::Link {
 public:
  Port(std::shared_ptr<State> state, uint32_t baud, bool discard_echo)
      : s_(std::move(state)), baud_(baud), discard_echo_(discard_echo) {}
  ~Port() override { s_->port_open = false; }
  Port(const Port&) = delete;
  Port& operator=(const Port&) = delete;

  void write(std::span<const uint8_t> bytes) override {
    if (bytes.empty()) return;
    // The other master's queries that started before ours are on the line first.
    s_->catch_up(s_->clock.now());
    // Our query occupies the wire for its length at our rate; its last byte is in then.
    const TimePoint end = s_->clock.now() + s_->wire(bytes.size(), baud_);
    s_->clock.set(end);
    if (s_->wrong_baud()) {
      s_->feed(sim::garble_wrong_baud(bytes), end);
    } else {
      s_->feed(bytes, end);
    }
    if (s_->options.echo_adapter) s_->hear(bytes, end, s_->wire(1, baud_), true);
    if (discard_echo_) swallow_echo(bytes);
  }

  std::size_t read_some(std::span<uint8_t> buffer, TimePoint deadline) override {
    VirtualClock& clock = s_->clock;
    for (;;) {
      s_->catch_up(clock.now());
      // What has arrived by now is there to read, also past the deadline (as SimLink).
      if (!s_->inbox.empty()) return s_->take_into(buffer);
      const TimePoint until = std::max(deadline, clock.now());
      const auto next = s_->next_event();
      if (!next || *next > until) {
        clock.set(until);
        s_->catch_up(until);
        return s_->inbox.empty() ? 0 : s_->take_into(buffer);
      }
      clock.set(std::max(*next, clock.now()));
    }
  }

  void discard_input() override {
    s_->catch_up(s_->clock.now());
    s_->inbox.clear();
  }

  const Clock& clock() const override { return s_->clock; }
  uint32_t baud() const override { return baud_; }
  std::string describe() const override {
    return "virtual line @ " + std::to_string(baud_) + " (in-process twin, virtual time)";
  }

 private:
  // As transport::SerialLink::swallow_echo: exactly the bytes sent, back in time.
  void swallow_echo(std::span<const uint8_t> sent) {
    modbus::Bytes echo(sent.size());
    const Duration allowed = s_->wire(sent.size(), baud_) + kVirtualEchoTimeout;
    const std::size_t got = client::read_until_full(*this, echo, s_->clock.now() + allowed);
    const std::span<const uint8_t> echoed(echo.data(), got);
    const bool prefix_matches = std::equal(echoed.begin(), echoed.end(), sent.begin());
    if (got == sent.size() && prefix_matches) return;
    const std::string what = prefix_matches ? "incomplete local echo on " : "bus collision on ";
    throw client::LinkError(client::LinkErrorKind::EchoMismatch,
                            what + describe() + ": sent " + modbus::to_hex(sent) + ", echoed " +
                                modbus::to_hex(echoed));
  }

  std::shared_ptr<State> s_;
  uint32_t baud_;
  bool discard_echo_;
};

VirtualLine::VirtualLine(sim::Bus& bus, VirtualClock& clock, VirtualLineOptions options)
    : state_(std::make_shared<State>(bus, clock, options)) {}

VirtualLine::~VirtualLine() = default;

std::unique_ptr<client::Link> VirtualLine::open(uint32_t baud, bool discard_echo) {
  if (state_->port_open) {
    throw client::LinkError(client::LinkErrorKind::PortUnavailable,
                            "the virtual line's port is already open (one link at a time)");
  }
  if (baud == 0) throw InvalidArgument("a port needs a baud rate");
  // Opened anew: what had arrived is flushed; what is on its way still comes.
  state_->catch_up(state_->clock.now());
  state_->inbox.clear();
  state_->baud = baud;
  state_->port_open = true;
  return std::make_unique<Port>(state_, baud, discard_echo);
}

}  // namespace lec6::twin
