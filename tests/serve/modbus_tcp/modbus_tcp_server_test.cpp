// The Modbus TCP listener's bounds and priorities, with real sockets on
// 127.0.0.1 and a Line over the twin on a virtual clock that the test drives
// by hand (run_once): requests stay queued until the test lets the line run,
// so what the server queues is exactly observable.

#include "modbus_tcp/modbus_tcp_server.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <asio.hpp>
#include <atomic>
#include <future>
#include <mutex>
#include <set>
#include <thread>

#include "lec6/client/rtu_master.hpp"
#include "lec6/modbus/mbap.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/twin/sim_link.hpp"

namespace lec6::serve {
namespace {

using namespace std::chrono_literals;
using asio::ip::tcp;

// Polls `done` until it holds or `within` passes (a wait on an event with a deadline).
bool eventually(const std::function<bool()>& done, std::chrono::milliseconds within = 10s) {
  const auto end = std::chrono::steady_clock::now() + within;
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(1ms);
  }
  return true;
}

modbus::Bytes mbap(uint16_t transaction, uint8_t unit, const modbus::Request& r) {
  return modbus::encode_mbap(transaction, unit, *modbus::encode_request_pdu(r));
}

const modbus::Request kReadState = modbus::ReadRegistersRequest{0x9000, 7};
const modbus::Request kResetOn = modbus::WriteCoilRequest{0x1B, modbus::kCoilOn};

struct Rig {
  explicit Rig(ModbusTcpLimits limits = {},
               ModbusTcpServer::Framing framing = ModbusTcpServer::Framing::Mbap) {
    for (uint8_t id : {1, 2}) bus.add(id, {}, clock.now());
    LineOptions o;
    o.name = "line1";
    o.port = "sim";
    line = std::make_unique<Line>(
        o,
        [this] {
          Wire w;
          w.master = std::make_unique<client::RtuMaster>(link);
          return w;
        },
        clock);
    GatewayPolicy policy;
    policy.units = {1, 2};
    server = std::make_unique<ModbusTcpServer>(
        io, ListenerConfig{}, framing, *line, policy,
        [this](LogLevel, std::string_view text) {
          std::lock_guard lock(log_mutex);
          log.emplace_back(text);
        },
        limits);
    thread = std::thread([this] { io.run(); });
  }
  ~Rig() {
    asio::post(io, [this] { server->stop(); });
    guard.reset();
    io.stop();
    thread.join();
    server.reset();
    line.reset();
  }
  tcp::socket connect() {
    tcp::socket s(client_io);
    s.connect({asio::ip::make_address("127.0.0.1"), server->port()});
    return s;
  }
  std::size_t queued(Priority p) const { return line->stats().queue_depth[index(p)]; }
  std::size_t queued() const {
    std::size_t n = 0;
    for (auto d : line->stats().queue_depth) n += d;
    return n;
  }
  bool logged(std::string_view what) {
    std::lock_guard lock(log_mutex);
    for (const auto& l : log) {
      if (l.find(what) != std::string::npos) return true;
    }
    return false;
  }
  std::size_t connections() {
    std::promise<std::size_t> p;
    asio::post(io, [&] { p.set_value(server->connections()); });
    return p.get_future().get();
  }

  VirtualClock clock{TimePoint{} + 1s};
  sim::Bus bus;
  twin::SimLink link{bus, clock};
  std::unique_ptr<Line> line;
  asio::io_context io;
  asio::executor_work_guard<asio::io_context::executor_type> guard = asio::make_work_guard(io);
  std::unique_ptr<ModbusTcpServer> server;
  std::thread thread;
  asio::io_context client_io;
  std::mutex log_mutex;
  std::vector<std::string> log;
};

// Reads one MBAP reply (header + PDU); its transaction id.
uint16_t read_reply(tcp::socket& s) {
  std::array<uint8_t, 7> header{};
  asio::read(s, asio::buffer(header));
  const std::size_t length = (header[4] << 8 | header[5]) - 1;
  std::vector<uint8_t> pdu(length);
  asio::read(s, asio::buffer(pdu));
  return static_cast<uint16_t>(header[0] << 8 | header[1]);
}

// True when the peer closed the connection (EOF), within `within`.
bool closed_by_server(tcp::socket& s, std::chrono::milliseconds within) {
  s.non_blocking(true);
  const auto end = std::chrono::steady_clock::now() + within;
  std::array<uint8_t, 64> b{};
  while (std::chrono::steady_clock::now() < end) {
    asio::error_code ec;
    s.read_some(asio::buffer(b), ec);
    if (ec == asio::error::eof || ec == asio::error::connection_reset) return true;
    std::this_thread::sleep_for(2ms);
  }
  return false;
}

// One MBAP reply: its transaction id and its PDU.
std::pair<uint16_t, std::vector<uint8_t>> read_reply_pdu(tcp::socket& s) {
  std::array<uint8_t, 7> header{};
  asio::read(s, asio::buffer(header));
  std::vector<uint8_t> pdu((header[4] << 8 | header[5]) - 1);
  asio::read(s, asio::buffer(pdu));
  return {static_cast<uint16_t>(header[0] << 8 | header[1]), pdu};
}

TEST(ModbusTcpServer, OneLargeWriteOfManyRequestsQueuesAtMostTheLimit) {
  ModbusTcpLimits limits;
  limits.max_queued = 8;
  Rig rig(limits);
  auto s = rig.connect();
  modbus::Bytes burst;
  for (uint16_t t = 1; t <= 100; ++t) {
    const auto f = mbap(t, 2, kReadState);
    burst.insert(burst.end(), f.begin(), f.end());
  }
  asio::write(s, asio::buffer(burst));  // 1 200 bytes: ~100 frames in one read
  ASSERT_TRUE(eventually([&] { return rig.queued() == 8; }));
  // 8 on the line, 8 waiting for room; the other 84 are answered at once
  // with exception 06 (server busy), before the line has run at all.
  s.non_blocking(false);
  std::vector<uint16_t> busy;
  for (int i = 0; i < 84; ++i) {
    const auto [t, pdu] = read_reply_pdu(s);
    ASSERT_EQ(pdu.size(), 2u) << "transaction " << t;
    EXPECT_EQ(pdu[0], 0x83);
    EXPECT_EQ(pdu[1], 0x06);
    busy.push_back(t);
  }
  EXPECT_EQ(busy.front(), 17);
  EXPECT_EQ(busy.back(), 100);
  EXPECT_TRUE(rig.logged("exception 06 (server busy)"));
  EXPECT_EQ(rig.queued(), 8u);
  // The 16 taken go as answers go out, in order, never more than 8 queued.
  // Each run_once() is one transaction, so one answer.
  std::vector<uint16_t> answered;
  for (int i = 0; i < 16; ++i) {
    ASSERT_TRUE(eventually([&] { return rig.queued() > 0; })) << "after " << i << " answers";
    ASSERT_LE(rig.queued(), 8u);
    rig.line->run_once();
    answered.push_back(read_reply(s));
  }
  EXPECT_EQ(answered.front(), 1);
  EXPECT_EQ(answered.back(), 16);
  EXPECT_EQ(rig.queued(), 0u);
}

// issue 31 rule 4: a PLC that pipelines far more than the connection holds
// and then writes RESET still has its stop on the line at once (it was read
// only after ~2x max_queued answers went out before).
TEST(ModbusTcpServer, AStopBehindAFloodOfPipelinedRequestsGoesAtOnce) {
  ModbusTcpLimits limits;
  limits.max_queued = 8;
  Rig rig(limits);
  auto s = rig.connect();
  modbus::Bytes burst;
  for (uint16_t t = 1; t <= 300; ++t) {
    const auto f = mbap(t, 1, kReadState);
    burst.insert(burst.end(), f.begin(), f.end());
  }
  const auto stop = mbap(999, 1, kResetOn);
  burst.insert(burst.end(), stop.begin(), stop.end());
  asio::write(s, asio::buffer(burst));
  ASSERT_TRUE(eventually([&] { return rig.queued(Priority::Emergency) == 1; }))
      << "the stop behind 300 reads was not taken while none was answered";
  EXPECT_LE(rig.queued(Priority::Command), 16u);
  // The stop's answer comes; every frame sent is answered (data or 06).
  s.non_blocking(false);
  std::set<uint16_t> seen;
  bool stop_answered = false;
  for (int i = 0; i < 40 && !stop_answered; ++i) rig.line->run_once();
  while (seen.size() < 301) {
    if (rig.queued() > 0) rig.line->run_once();
    const auto [t, pdu] = read_reply_pdu(s);
    EXPECT_TRUE(seen.insert(t).second) << "transaction " << t << " answered twice";
    if (t == 999) {
      stop_answered = true;
      // The controller's own answer (the twin, not in serial mode, answers
      // 02), never the gateway's busy.
      EXPECT_FALSE(pdu.size() == 2 && pdu[1] == 0x06) << "the stop was refused as busy";
    }
  }
  EXPECT_TRUE(stop_answered);
}

TEST(ModbusTcpServer, ConnectionsBeyondTheCapAreClosedWithALogLine) {
  ModbusTcpLimits limits;
  limits.max_connections = 3;
  Rig rig(limits);
  std::vector<tcp::socket> open;
  for (int i = 0; i < 3; ++i) open.push_back(rig.connect());
  ASSERT_TRUE(eventually([&] { return rig.connections() == 3; }));
  auto extra = rig.connect();
  EXPECT_TRUE(closed_by_server(extra, 5s));
  EXPECT_EQ(rig.connections(), 3u);
  EXPECT_TRUE(eventually([&] { return rig.logged("refused the connection"); }));
  // The open ones still work.
  asio::write(open[0], asio::buffer(mbap(7, 1, kReadState)));
  ASSERT_TRUE(eventually([&] { return rig.queued() == 1; }));
  rig.line->run_once();
  open[0].non_blocking(false);
  EXPECT_EQ(read_reply(open[0]), 7);
}

TEST(ModbusTcpServer, AnIdleConnectionIsClosedButNotOneThatIsOwedAnAnswer) {
  ModbusTcpLimits limits;
  limits.idle_timeout = 200ms;
  Rig rig(limits);
  auto idle = rig.connect();
  auto waiting = rig.connect();
  asio::write(waiting, asio::buffer(mbap(3, 1, kReadState)));  // the line is not run: owed
  ASSERT_TRUE(eventually([&] { return rig.queued() == 1; }));
  EXPECT_TRUE(closed_by_server(idle, 10s));
  EXPECT_TRUE(rig.logged("no request for"));
  EXPECT_FALSE(closed_by_server(waiting, 600ms)) << "closed while an answer was owed";
  rig.line->run_once();
  waiting.non_blocking(false);
  EXPECT_EQ(read_reply(waiting), 3);
}

TEST(ModbusTcpServer, APlcResetOvertakesEveryOtherClientsQueuedReads) {
  Rig rig;
  std::vector<tcp::socket> scada;
  for (int c = 0; c < 20; ++c) {
    scada.push_back(rig.connect());
    modbus::Bytes burst;
    for (uint16_t t = 1; t <= 8; ++t) {
      const auto f = mbap(t, 2, kReadState);
      burst.insert(burst.end(), f.begin(), f.end());
    }
    asio::write(scada.back(), asio::buffer(burst));
  }
  ASSERT_TRUE(eventually([&] { return rig.queued(Priority::Command) == 160; }));
  auto plc = rig.connect();
  asio::write(plc, asio::buffer(mbap(42, 1, kResetOn)));
  ASSERT_TRUE(eventually([&] { return rig.queued(Priority::Emergency) == 1; }));
  rig.line->run_once();  // one transaction: the RESET's
  plc.non_blocking(false);
  EXPECT_EQ(read_reply(plc), 42);
  EXPECT_EQ(rig.queued(Priority::Command), 160u);
}

}  // namespace
}  // namespace lec6::serve

namespace lec6::serve {
namespace {

// Issue 33 rule 4 over RTU over TCP: FC06 is a function the gateway takes, so
// its frame has a known length (8 bytes). A PLC that pipelines an FC06 and a
// stop in one TCP segment must have both taken; the stop most of all. Today
// the listener sizes FC06 as "unknown" (all that arrived), the CRC over both
// frames fails, and the buffer is dropped: the stop is silently lost.
TEST(ModbusTcpServer, RtuOverTcpAnFc06PipelinedWithAStopLosesNeither) {
  Rig rig({}, ModbusTcpServer::Framing::Rtu);
  auto s = rig.connect();
  modbus::Bytes burst = {0x01, 0x06, 0x91, 0x02, 0x00, 0x01};  // D9102 <- 1, FC06
  modbus::append_crc(burst);
  const auto stop = *modbus::encode_request({1, kResetOn});
  burst.insert(burst.end(), stop.begin(), stop.end());
  asio::write(s, asio::buffer(burst));
  // Both queued: the stop in the emergency lane, the FC06 (an earlier write
  // to the same controller) ahead of it, in order (scheduler.hpp).
  EXPECT_TRUE(eventually([&] { return rig.queued(Priority::Emergency) >= 1; }, 2s))
      << "the RESET written right after an FC06 never reached the line";
  EXPECT_TRUE(eventually([&] { return rig.queued() == 2; }, 2s))
      << "the FC06 was dropped: " << rig.queued() << " queued";
}

}  // namespace
}  // namespace lec6::serve
