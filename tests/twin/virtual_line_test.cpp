// twin::VirtualLine: the line faults lec sim plays on a pty (echo, wrong baud,
// another master, a USB adapter's latency timer) and the bus's own (Td,
// noise), on a virtual clock: every wait is a clock jump, and every instant
// is checked exactly where the timing rule gives one.

#include "lec6/twin/virtual_line.hpp"

#include <gtest/gtest.h>

#include <array>
#include <utility>
#include <vector>

#include "lec6/client/client.hpp"
#include "lec6/client/doctor.hpp"
#include "lec6/client/errors.hpp"
#include "lec6/client/rtu_master.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/sim/usb_latency.hpp"

namespace lec6::twin {
namespace {

using namespace std::chrono_literals;
namespace dx = client::doctor;

constexpr uint32_t kVlBaud = 38400;  // the bus's (sim::LineConfig's default)
constexpr std::size_t kVlReplyBytes = 5 + 2 * lec::kStateDataRegisters;

modbus::Bytes vl_state_query(uint8_t id) {
  return *modbus::encode_request(
      {id, modbus::ReadRegistersRequest{lec::kStateData, lec::kStateDataRegisters}});
}

// Twins on a bus, the line, and a virtual clock that starts at 1 s.
struct VlRig {
  explicit VlRig(VirtualLineOptions o = {}, sim::LineConfig line = {}, sim::FaultConfig faults = {},
                 const std::vector<uint8_t>& ids = {1})
      : bus(line, faults), vl(add_all(bus, ids, clock.now()), clock, o) {}

  // The twins go on the bus before the line is made.
  static sim::Bus& add_all(sim::Bus& b, const std::vector<uint8_t>& ids, TimePoint at) {
    for (uint8_t id : ids) b.add(id, {}, at);
    return b;
  }

  const modbus::LineTiming& timing() const { return bus.line().line; }

  VirtualClock clock{TimePoint{} + 1s};
  const TimePoint origin = clock.now();
  sim::Bus bus;
  VirtualLine vl;
};

// Everything heard until `until`, as lec doctor listens.
modbus::Bytes vl_listen(client::Link& link, TimePoint until) {
  modbus::Bytes heard;
  std::array<uint8_t, 512> buf{};
  while (link.clock().now() < until) {
    const std::size_t n = link.read_some(buf, until);
    heard.insert(heard.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
  }
  return heard;
}

struct VlHeard {
  modbus::Bytes bytes;
  dx::ExchangeResult result;
  Duration round_trip{};                            // first byte sent -> a sound reply complete
  std::vector<std::pair<TimePoint, size_t>> reads;  // when each read_some returned, and how much
};

// Sends `query` and reads until a sound reply is complete or `window` passes
// after the query (lec doctor's exchange, without its wait for silence).
VlHeard vl_exchange(client::Link& link, const modbus::Bytes& query, Duration window = 200ms) {
  VlHeard h;
  const TimePoint start = link.clock().now();
  link.write(query);
  const TimePoint deadline = link.clock().now() + window;
  std::array<uint8_t, 512> buf{};
  while (link.clock().now() < deadline) {
    const std::size_t n = link.read_some(buf, deadline);
    if (n == 0) continue;
    h.reads.emplace_back(link.clock().now(), n);
    h.bytes.insert(h.bytes.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
    if (dx::answered(dx::classify_exchange(query, h.bytes).kind)) {
      h.round_trip = link.clock().now() - start;
      break;
    }
  }
  h.result = dx::classify_exchange(query, h.bytes);
  return h;
}

TEST(VirtualLine, ASoundReadThroughTheClientAtTheLinesBaud) {
  VlRig r;
  auto link = r.vl.open(kVlBaud);
  EXPECT_EQ(link->baud(), kVlBaud);
  client::RtuMaster master(*link, client::RtuOptions{});
  client::Client c(master, {.id = 1, .retries = 0});
  EXPECT_NO_THROW(c.read_state());
  EXPECT_EQ(r.bus.stats().replies, 1u);
  // On the clock the line's own time: query, Ts, T0, Td, reply (the wait for silence before it).
  EXPECT_GE(r.clock.now() - r.origin, r.timing().transaction_limit(8, kVlReplyBytes));
  EXPECT_LT(r.clock.now() - r.origin, 50ms);
}

TEST(VirtualLine, AQueryAtTheWrongBaudGetsNoSoundReply) {
  VlRig r;
  auto link = r.vl.open(9600);
  const VlHeard h = vl_exchange(*link, vl_state_query(1));
  EXPECT_FALSE(dx::answered(h.result.kind));
  EXPECT_EQ(r.bus.stats().replies, 0u) << "the controller heard a garbled query";
  EXPECT_GE(r.bus.stats().bad_frames, 1u);
  // Through the client: no answer at all.
  client::RtuMaster master(*link, client::RtuOptions{});
  client::Client c(master, {.id = 1, .retries = 1});
  EXPECT_THROW(c.read_state(), client::TransportError);
  EXPECT_EQ(r.bus.stats().replies, 0u);
}

TEST(VirtualLine, AtTheWrongBaudTheOtherMastersTrafficIsHeardGarbled) {
  VlRig r({.other_master_period = 20ms});
  {
    auto link = r.vl.open(19200);
    const modbus::Bytes heard = vl_listen(*link, r.origin + 200ms);
    EXPECT_FALSE(heard.empty()) << "bytes are heard, only garbled";
    EXPECT_TRUE(dx::foreign_queries(heard).empty());
  }
  // The same line at its own rate: the other master's queries are sound.
  auto link = r.vl.open(kVlBaud);
  const modbus::Bytes heard = vl_listen(*link, r.origin + 400ms);
  // The queries at 220 ... 380 ms (the one at 400 ms is not all in by then).
  EXPECT_EQ(dx::foreign_queries(heard), std::vector<uint8_t>(9, 1));
}

TEST(VirtualLine, AnEchoingAdapterGivesTheQueryBackFirst) {
  VlRig r({.echo_adapter = true});
  auto link = r.vl.open(kVlBaud);
  const modbus::Bytes query = vl_state_query(1);
  const VlHeard h = vl_exchange(*link, query);
  ASSERT_GE(h.bytes.size(), query.size());
  EXPECT_EQ(modbus::Bytes(h.bytes.begin(), h.bytes.begin() + 8), query);
  EXPECT_TRUE(h.result.echo);
  EXPECT_EQ(h.result.kind, dx::ReplyKind::Good);
  // The echo is there as the query's last byte leaves: read with no wait.
  ASSERT_FALSE(h.reads.empty());
  EXPECT_EQ(h.reads.front().first, r.origin + r.timing().wire_time(query.size()));
}

TEST(VirtualLine, AnEchoIsNotGarbledAtTheWrongBaud) {
  VlRig r({.echo_adapter = true});
  auto link = r.vl.open(19200);
  const modbus::Bytes query = vl_state_query(1);
  const VlHeard h = vl_exchange(*link, query);
  EXPECT_EQ(h.bytes, query) << "the echo, and no reply";
  EXPECT_TRUE(h.result.echo);
  EXPECT_EQ(h.result.kind, dx::ReplyKind::None);
}

TEST(VirtualLine, WithEchoDiscardAClientTransactionWorks) {
  VlRig r({.echo_adapter = true});
  auto link = r.vl.open(kVlBaud, true);
  client::RtuMaster master(*link, client::RtuOptions{});
  client::Client c(master, {.id = 1, .retries = 0});
  EXPECT_NO_THROW(c.read_state());
  EXPECT_NO_THROW(c.read_state());
  EXPECT_EQ(master.stats().bytes_discarded, 0u);
}

TEST(VirtualLine, EchoDiscardWithoutAnEchoIsAnEchoMismatchAsOnASerialPort) {
  VlRig r;
  auto link = r.vl.open(kVlBaud, true);
  try {
    link->write(vl_state_query(1));
    FAIL() << "no echo came back";
  } catch (const client::LinkError& e) {
    EXPECT_EQ(e.kind(), client::LinkErrorKind::EchoMismatch) << e.what();
  }
}

TEST(VirtualLine, AnotherMasterEvery20msIsHeardInHalfASecond) {
  VlRig r({.other_master_period = 20ms});
  auto link = r.vl.open(kVlBaud);
  const modbus::Bytes heard = vl_listen(*link, r.origin + 500ms);
  // Queries start at 20, 40, ... 500 ms; the one at 500 ms is not all in by then.
  EXPECT_EQ(dx::foreign_queries(heard), std::vector<uint8_t>(24, 1));
  EXPECT_EQ(heard.size(), 24 * (8 + kVlReplyBytes)) << "each query and its reply";
  EXPECT_EQ(r.clock.now(), r.origin + 500ms);
}

TEST(VirtualLine, AReadWakesAtTheOtherMastersQuery) {
  VlRig r({.other_master_period = 20ms, .other_master_id = 3}, {}, {}, {1, 3});
  auto link = r.vl.open(kVlBaud);
  std::array<uint8_t, 64> buf{};
  const std::size_t n = link->read_some(buf, r.origin + 1s);
  EXPECT_EQ(r.clock.now(), r.origin + 20ms + r.timing().wire_time(8));
  EXPECT_EQ(modbus::Bytes(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n)),
            vl_state_query(3));
}

TEST(VirtualLine, AWriteFirstPutsTheOtherMastersDueQueriesOnTheLine) {
  VlRig r({.other_master_period = 25ms}, {}, {}, {1, 2});
  auto link = r.vl.open(kVlBaud);
  r.clock.set(r.origin + 55ms);  // nobody read meanwhile: the queries at 25 and 50 ms are due
  link->write(vl_state_query(2));
  // Our reply ends at about 72 ms (after the second reply), before the query at 75 ms.
  const modbus::Bytes heard = vl_listen(*link, r.origin + 74ms);
  // Their query and reply twice, then our reply, in the order they were on the line.
  const std::size_t pair = 8 + kVlReplyBytes;
  ASSERT_EQ(heard.size(), 2 * pair + kVlReplyBytes);
  const modbus::Bytes theirs = vl_state_query(1);
  EXPECT_EQ(modbus::Bytes(heard.begin(), heard.begin() + 8), theirs);
  EXPECT_EQ(heard[8], 1);
  EXPECT_EQ(modbus::Bytes(heard.begin() + pair, heard.begin() + pair + 8), theirs);
  EXPECT_EQ(heard[pair + 8], 1);
  EXPECT_EQ(heard[2 * pair], 2) << "our reply last";
  EXPECT_EQ(r.bus.stats().replies, 3u);
}

TEST(VirtualLine, AUsbAdapterHandsTheReplyOverAtItsTimerTicks) {
  VlRig r({.usb_latency = 16ms});
  auto link = r.vl.open(kVlBaud);
  r.clock.set(r.origin + 3ms);  // off the ticks
  const TimePoint start = r.clock.now();
  const VlHeard h = vl_exchange(*link, vl_state_query(1));
  ASSERT_EQ(h.result.kind, dx::ReplyKind::Good);
  const TimePoint reply_end = start + r.timing().transaction_limit(8, kVlReplyBytes);
  const sim::UsbLatency ticks(16ms, sim::UsbLatency::kFtdiPacketBytes, r.origin);
  ASSERT_GE(h.reads.size(), 2u) << "a reply across a tick comes in two lumps";
  std::size_t got = 0;
  for (const auto& [at, n] : h.reads) {
    EXPECT_EQ((at - r.origin) % 16ms, Duration::zero()) << "a lump off the ticks";
    got += n;
  }
  EXPECT_EQ(got, kVlReplyBytes);
  EXPECT_LT(h.reads.front().first, reply_end) << "the reply's first bytes at the tick within it";
  EXPECT_EQ(h.reads.back().first, ticks.tick_after(reply_end));
}

TEST(VirtualLine, ATdOf20msIsInTheRoundTrip) {
  sim::LineConfig line;
  line.line.delay_td = 20ms;
  VlRig r({}, line);
  auto link = r.vl.open(kVlBaud);
  const VlHeard h = vl_exchange(*link, vl_state_query(1));
  ASSERT_EQ(h.result.kind, dx::ReplyKind::Good);
  EXPECT_GE(h.round_trip, 20ms);
  EXPECT_EQ(h.round_trip, line.line.transaction_limit(8, kVlReplyBytes));
}

TEST(VirtualLine, TheMasterHearsTheLinesNoise) {
  sim::FaultConfig faults;
  faults.noise_rate = 200;
  VlRig r({}, {}, faults);
  auto link = r.vl.open(kVlBaud);
  const modbus::Bytes heard = vl_listen(*link, r.origin + 1s);
  EXPECT_GT(heard.size(), 100u);
  EXPECT_EQ(heard.size(), r.bus.stats().noise_bytes);
}

TEST(VirtualLine, OnePortAtATimeAndTheLineGoesOnBetweenThem) {
  VlRig r({.other_master_period = 20ms});
  auto first = r.vl.open(kVlBaud);
  try {
    r.vl.open(kVlBaud);
    FAIL() << "a second port while the first is open";
  } catch (const client::LinkError& e) {
    EXPECT_EQ(e.kind(), client::LinkErrorKind::PortUnavailable);
  }
  first.reset();
  // Closed at 30 ms: the query at 20 ms arrived meanwhile and is flushed when
  // the port opens; its reply, still on its way, is heard, then the next query.
  r.clock.set(r.origin + 30ms);
  auto second = r.vl.open(kVlBaud);
  const modbus::Bytes heard = vl_listen(*second, r.origin + 50ms);
  ASSERT_EQ(heard.size(), kVlReplyBytes + 8);
  EXPECT_EQ(heard[0], 1);
  EXPECT_EQ(modbus::Bytes(heard.end() - 8, heard.end()), vl_state_query(1));
}

}  // namespace
}  // namespace lec6::twin
