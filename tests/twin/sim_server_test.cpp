// The twin's event loop on real pseudo-terminals and sockets: a server on a
// thread, masters through SerialLink / TcpLink. Timing is checked as ratios
// to the wire limit (digest §1), never as absolute times: a reply never comes
// before the limit (it holds under any load), and its median stays within a
// margin that holds under ASan + UBSan on a loaded 2-core machine too. How
// close to the limit the twin really is (1.00x-1.01x) is measured by the
// benchmark, not here: bench/poll_bus.cpp, `make bench` (BENCHMARKS.md).

#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <future>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "lec6/error.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/transport/serial_link.hpp"
#include "lec6/transport/tcp_link.hpp"
#include "lec6/twin/sim_server.hpp"
#include "lec6/twin/state_file_io.hpp"
#include "read_link.hpp"
#include "twin/served_twin.hpp"

namespace lec6::twin {
using namespace transport;
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using Bytes = std::vector<uint8_t>;
using ::testing::HasSubstr;

const SteadyClock kClock;

Bytes frame(uint8_t id, const modbus::Request& request) {
  auto bytes = modbus::encode_request({id, request});
  EXPECT_TRUE(bytes.has_value());
  return bytes ? *bytes : Bytes{};
}

// Read D9000–D9006 (the state area: position, speed, thrust, target, step).
Bytes read_state(uint8_t id = 1) {
  return frame(id, modbus::ReadRegistersRequest{0x9000, 7});
}
constexpr std::size_t kReadStateReply = 5 + 14;

Bytes echo(uint8_t id, uint16_t data) {
  return frame(id, modbus::EchoRequest{0, data});
}

using testing::read_link;

class ScratchDir {
 public:
  ScratchDir() {
    std::string pattern = (fs::temp_directory_path() / "lec6-simserver-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = pattern;
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

using testing::pty_only;
using ServedTwin = testing::ServedTwin;

// Round trip / limit. Scheduling (a loaded machine, sanitizers) only ever
// adds delay, so the best of N round trips shows the twin's own timing: within
// kBestMargin of the limit (1.01 unloaded, up to 1.18 at a load average of 13 on 2
// cores, where the median was 2.6). The median only has to show no
// systematic lateness (a wake-up left to a timeout). The exact timing (Ts,
// 4 ms, Td, wire times) is proved on a virtual clock (tests/sim
// Line.RealTimingReplyEndsAtTheLimit, tests/client
// Client.ReadStateTakesExactlyTheWireLimitInRealTiming).
constexpr double kBestMargin = 1.5;
constexpr double kMedianMargin = 4.0;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// ---- timing --------------------------------------------------------------------

// The client measures from before its write to the complete reply, as our
// benchmark does; on a pty that must come out at the limit (wire(query) + Ts +
// 4 ms + Td + wire(reply)): never below it, and the median within the margin.
TEST(SimServer, ReadStateRoundTripOnAPtyMatchesTheLimit) {
  ServedTwin twin({1}, pty_only());
  SerialLink link(twin.server().pty()->slave_path(), SerialOptions{.baud = 38400});
  const Bytes query = read_state();
  const Duration limit = modbus::LineTiming{}.transaction_limit(query.size(), kReadStateReply);

  std::vector<double> ratios;
  for (int i = 0; i < 25; ++i) {
    const TimePoint t0 = kClock.now();
    link.write(query);
    const Bytes reply = read_link(link, kReadStateReply);
    const TimePoint t1 = kClock.now();
    ASSERT_EQ(reply.size(), kReadStateReply);
    ASSERT_TRUE(modbus::decode_response(reply).has_value());
    const double ratio = to_seconds(t1 - t0) / to_seconds(limit);
    EXPECT_GE(ratio, 1.0) << "a reply came before the controller could have sent it";
    ratios.push_back(ratio);
  }
  const double m = median(ratios);
  RecordProperty("median_ratio_to_limit", std::to_string(m));
  std::printf("read-state round trip / limit: median %.4f, min %.4f, max %.4f\n", m,
              *std::min_element(ratios.begin(), ratios.end()),
              *std::max_element(ratios.begin(), ratios.end()));
  const auto st = twin.server().stats();
  std::printf("twin write lateness: mean %.1f us, max %.1f us over %llu replies\n",
              to_ms(st.lateness_total) * 1000.0 / static_cast<double>(st.replies_sent),
              to_ms(st.lateness_max) * 1000.0, static_cast<unsigned long long>(st.replies_sent));
  EXPECT_LE(*std::min_element(ratios.begin(), ratios.end()), kBestMargin)
      << "the best of " << ratios.size() << " round trips";
  EXPECT_LE(m, kMedianMargin) << "median of " << ratios.size() << " round trips";
}

TEST(SimServer, SlowerLineAndLongerDelayStretchTheRoundTripToItsLimit) {
  sim::LineConfig line;
  line.line.baud = 9600;
  line.line.silent_interval_k = 2;
  line.line.delay_td = std::chrono::milliseconds(8);
  ServedTwin twin({1}, pty_only(), line);
  SerialLink link(twin.server().pty()->slave_path(), SerialOptions{.baud = 9600});
  const Bytes query = echo(1, 0x1234);
  const Duration limit = line.line.transaction_limit(query.size(), query.size());
  std::vector<double> ratios;
  for (int i = 0; i < 7; ++i) {
    const TimePoint t0 = kClock.now();
    link.write(query);
    ASSERT_EQ(read_link(link, query.size()), query);
    const double ratio = to_seconds(kClock.now() - t0) / to_seconds(limit);
    EXPECT_GE(ratio, 1.0);
    ratios.push_back(ratio);
  }
  EXPECT_LE(*std::min_element(ratios.begin(), ratios.end()), kBestMargin);
  EXPECT_LE(median(ratios), kMedianMargin);
}

TEST(SimServer, FastTimingAnswersWellWithinTheLimit) {
  sim::LineConfig line;
  line.timing = sim::Timing::Fast;
  ServedTwin twin({1}, pty_only(), line);
  SerialLink link(twin.server().pty()->slave_path());
  const Bytes query = read_state();
  const Duration limit = line.line.transaction_limit(query.size(), kReadStateReply);
  std::vector<double> ratios;
  for (int i = 0; i < 15; ++i) {
    const TimePoint t0 = kClock.now();
    link.write(query);
    ASSERT_EQ(read_link(link, kReadStateReply).size(), kReadStateReply);
    ratios.push_back(to_seconds(kClock.now() - t0) / to_seconds(limit));
  }
  // Below the limit, which a real-timing reply never is (see above): the best
  // round trip (unloaded, the median is a few % of the limit).
  EXPECT_LT(*std::min_element(ratios.begin(), ratios.end()), 0.5);
}

// A query written in two pieces back to back is one frame: the virtual line
// carries them contiguously, with no silent interval between them. (At 9600
// baud with k = 10, Ts is 36 ms: a writer descheduled between its two writes
// on a loaded machine still falls inside it.)
TEST(SimServer, AQueryWrittenInPiecesIsOneFrame) {
  sim::LineConfig line;
  line.line.baud = 9600;
  line.line.silent_interval_k = 10;
  ServedTwin twin({1}, pty_only(), line);
  SerialLink link(twin.server().pty()->slave_path(), SerialOptions{.baud = 9600});
  const Bytes query = echo(1, 0xBEEF);
  link.write(std::span(query).first(3));
  link.write(std::span(query).subspan(3));
  EXPECT_EQ(read_link(link, query.size()), query);
}

// ---- routing, IDs, broadcast ------------------------------------------------------

TEST(SimServer, EachIdAnswersAndOthersAreSilent) {
  ServedTwin twin({1, 2, 3}, pty_only());
  SerialLink link(twin.server().pty()->slave_path());
  for (uint8_t id : {1, 2, 3}) {
    const Bytes q = echo(id, static_cast<uint16_t>(0x0100 + id));
    link.write(q);
    EXPECT_EQ(read_link(link, q.size()), q) << "ID " << int{id};
  }
  link.write(echo(4, 0x0404));
  // Tx for an 8-byte reply at 38400 is under 15 ms; wait well beyond it.
  EXPECT_TRUE(read_link(link, 1, 100ms).empty());
}

TEST(SimServer, BroadcastWriteActsWithoutAReply) {
  ServedTwin twin({1, 2}, pty_only());
  SerialLink link(twin.server().pty()->slave_path());
  link.write(frame(0, modbus::WriteCoilRequest{0x30, modbus::kCoilOn}));
  EXPECT_TRUE(read_link(link, 1, 100ms).empty());
  for (uint8_t id : {1, 2}) {
    const Bytes q = frame(id, modbus::ReadBitsRequest{modbus::FunctionCode::ReadCoils, 0x30, 1});
    link.write(q);
    const Bytes r = read_link(link, 6);
    ASSERT_EQ(r.size(), 6u);
    EXPECT_EQ(r[3] & 1, 1) << "Y30 of ID " << int{id};
  }
}

TEST(SimServer, TcpClientsShareTheBusAndGetTheirOwnReplies) {
  SimServerOptions o;
  o.tcp = std::make_pair(std::string("127.0.0.1"), uint16_t{0});
  o.pty = true;
  ServedTwin twin({1}, o);
  const uint16_t port = twin.server().tcp()->port();
  EXPECT_THAT(twin.server().endpoints(), HasSubstr("tcp://127.0.0.1:"));
  TcpLink a("127.0.0.1", port);
  TcpLink b("127.0.0.1", port);
  SerialLink p(twin.server().pty()->slave_path());
  for (int round = 0; round < 3; ++round) {
    const Bytes qa = echo(1, static_cast<uint16_t>(0xA000 + round));
    const Bytes qb = echo(1, static_cast<uint16_t>(0xB000 + round));
    const Bytes qp = echo(1, static_cast<uint16_t>(0xC000 + round));
    a.write(qa);
    EXPECT_EQ(read_link(a, qa.size()), qa);
    b.write(qb);
    EXPECT_EQ(read_link(b, qb.size()), qb);
    p.write(qp);
    EXPECT_EQ(read_link(p, qp.size()), qp);
  }
  // Nobody received anybody else's reply.
  EXPECT_TRUE(read_link(a, 1, 30ms).empty());
  EXPECT_TRUE(read_link(b, 1, 30ms).empty());
  EXPECT_TRUE(read_link(p, 1, 30ms).empty());
  EXPECT_EQ(twin.server().stats().connections, 2u);
}

TEST(SimServer, AClientThatLeavesBeforeItsReplyDoesNotDisturbOthers) {
  SimServerOptions o;
  o.tcp = std::make_pair(std::string("127.0.0.1"), uint16_t{0});
  ServedTwin twin({1}, o);
  const uint16_t port = twin.server().tcp()->port();
  {
    TcpLink gone("127.0.0.1", port);
    gone.write(echo(1, 0x1111));
  }  // closed before the reply is due
  TcpLink stays("127.0.0.1", port);
  // Let the first reply fall due (and be dropped) before asking.
  EXPECT_TRUE(read_link(stays, 1, 50ms).empty());
  const Bytes q = echo(1, 0x2222);
  stays.write(q);
  EXPECT_EQ(read_link(stays, q.size()), q);
}

// ---- life cycle ------------------------------------------------------------------

TEST(SimServer, StopEndsTheLoopPromptlyAndRemovesTheLink) {
  ScratchDir dir;
  SimServerOptions o = pty_only();
  o.pty_link = dir.path() / "lec0";
  auto twin = std::make_unique<ServedTwin>(std::vector<uint8_t>{1}, o);
  EXPECT_TRUE(fs::is_symlink(dir.path() / "lec0"));
  EXPECT_EQ(fs::read_symlink(dir.path() / "lec0"), fs::path(twin->server().pty()->slave_path()));
  const TimePoint t0 = kClock.now();
  twin->stop();
  EXPECT_TRUE(twin->done());
  EXPECT_LT(to_ms(kClock.now() - t0), 1000.0);
  twin.reset();
  EXPECT_FALSE(fs::exists(fs::symlink_status(dir.path() / "lec0")));
}

TEST(SimServer, StopBeforeRunReturnsAtOnce) {
  sim::Bus bus;
  bus.add(1);
  SimServer server(bus, pty_only());
  server.stop();
  // run() must return by itself: the stop was not lost. On a thread, so that
  // a lost stop fails here (and is then stopped again) instead of hanging.
  auto ran = std::async(std::launch::async, [&] { server.run(); });
  const bool returned = ran.wait_for(5s) == std::future_status::ready;
  if (!returned) server.stop();
  ran.get();
  EXPECT_TRUE(returned) << "run() after stop() did not return within 5 s";
}

TEST(SimServer, NeedsSomewhereToServe) {
  sim::Bus bus;
  EXPECT_THROW(SimServer(bus, SimServerOptions{}), lec6::InvalidArgument);
}

TEST(SimServer, SavesTheEepromWhenItChangesAndAtTheEnd) {
  ScratchDir dir;
  const fs::path state = dir.path() / "twin.state";
  SimServerOptions o = pty_only();
  o.state_file = state;
  o.save_interval = std::chrono::milliseconds(50);
  auto twin = std::make_unique<ServedTwin>(std::vector<uint8_t>{1}, o);
  SerialLink link(twin->server().pty()->slave_path());
  std::vector<uint16_t> step(16, 0);
  step[0] = 1;      // ABS
  step[1] = 100;    // mm/s
  step[3] = 15000;  // 150.00 mm
  const Bytes q = frame(1, modbus::WriteRegistersRequest::of(0x0410, step));
  link.write(q);
  ASSERT_EQ(read_link(link, 8).size(), 8u);
  // The debounced save lands without the twin stopping; wait for the file.
  const TimePoint deadline = kClock.now() + 5s;
  while (!fs::exists(state) && kClock.now() < deadline) std::this_thread::sleep_for(5ms);
  ASSERT_TRUE(fs::exists(state));
  twin->stop();
  auto loaded = load_state_file(state);
  ASSERT_TRUE(loaded.has_value()) << loaded.error();
  ASSERT_TRUE(loaded->has_value());
  const auto& e = (**loaded).at(1);
  EXPECT_EQ(e.steps[1], twin->bus().find(1)->eeprom().steps[1]);
  EXPECT_GE(e.step_writes[1], 1u);
  EXPECT_GE(twin->server().stats().saves, 1u);
  EXPECT_EQ(twin->server().stats().save_failures, 0u);
}

TEST(SimServer, TraceShowsEachFrameDecoded) {
  std::vector<std::string> lines;
  std::mutex m;
  SimServerOptions o = pty_only();
  o.trace = [&](const std::string& l) {
    std::lock_guard lock(m);
    lines.push_back(l);
  };
  ServedTwin twin({1}, o);
  SerialLink link(twin.server().pty()->slave_path());
  const Bytes q = echo(1, 0x1234);
  link.write(q);
  ASSERT_EQ(read_link(link, q.size()), q);
  link.write(echo(9, 0x1234));  // silence, still traced
  EXPECT_TRUE(read_link(link, 1, 60ms).empty());
  twin.stop();
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_THAT(lines[0], HasSubstr("<- 01 08 00 00 12 34"));
  EXPECT_THAT(lines[1], HasSubstr("-> 01 08 00 00 12 34"));
  EXPECT_THAT(lines[2], HasSubstr("<- 09 08"));
  EXPECT_THAT(lines[0], HasSubstr(" ms "));
}

}  // namespace
}  // namespace lec6::twin
