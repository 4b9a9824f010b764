// The twin's tap (`lec sim --tap`) and its USB latency (`--tap-latency`,
// `--usb-latency`) on real pseudo-terminals: a master on the pty, a listener
// on the tap hearing the query and the reply, byte for byte, in order.

#include <atomic>
#include <filesystem>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "lec6/modbus/pdu.hpp"
#include "lec6/transport/serial_link.hpp"
#include "lec6/twin/sim_server.hpp"
#include "read_link.hpp"

namespace lec6::twin {
namespace {

using namespace std::chrono_literals;
using modbus::Bytes;
using transport::SerialLink;
using transport::SerialOptions;

const SteadyClock kTapClock;

Bytes tap_read_state() {
  return *modbus::encode_request({1, modbus::ReadRegistersRequest{0x9000, 7}});
}
constexpr std::size_t kReplyBytes = 5 + 14;

// Up to `count` bytes before `timeout`.
Bytes read_bytes(client::Link& link, std::size_t count, Duration timeout = 3s) {
  return testing::read_link(link, count, timeout);
}

class Twin {
 public:
  explicit Twin(SimServerOptions options) {
    bus_.add(1, {}, kTapClock.now());
    server_ = std::make_unique<SimServer>(bus_, std::move(options));
    thread_ = std::thread([this] { server_->run(); });
  }
  ~Twin() {
    server_->stop();
    thread_.join();
  }
  SimServer& server() { return *server_; }

 private:
  sim::Bus bus_{sim::LineConfig{}};
  std::unique_ptr<SimServer> server_;
  std::thread thread_;
};

std::filesystem::path tap_path(const char* name) {
  return std::filesystem::temp_directory_path() /
         (std::string("lec6-tap-") + std::to_string(::getpid()) + "-" + name);
}

// The master's exchange as the tap hears it.
void expect_tap_hears_the_exchange(Duration tap_latency, Duration usb_latency) {
  SimServerOptions o;
  o.pty = true;
  o.tap_link = tap_path(tap_latency > 0s ? "lumped" : "plain");
  o.tap_latency = tap_latency;
  o.usb_latency = usb_latency;
  Twin twin(std::move(o));
  ASSERT_NE(twin.server().tap(), nullptr);
  SerialLink tap(twin.server().tap()->client_path(), SerialOptions{.baud = 38400});
  SerialLink master(twin.server().pty()->slave_path(), SerialOptions{.baud = 38400});
  for (int i = 0; i < 3; ++i) {
    const Bytes query = tap_read_state();
    master.write(query);
    const Bytes reply = read_bytes(master, kReplyBytes);
    ASSERT_EQ(reply.size(), kReplyBytes) << "exchange " << i;
    Bytes expected = query;
    expected.insert(expected.end(), reply.begin(), reply.end());
    EXPECT_EQ(read_bytes(tap, expected.size()), expected) << "exchange " << i;
  }
  EXPECT_EQ(twin.server().stats().tap_bytes_dropped, 0u);
}

TEST(Tap, CarriesTheQueryAndTheReply) {
  expect_tap_hears_the_exchange(0s, 0s);
}

TEST(Tap, InUsbLumpsCarriesTheSameBytes) {
  expect_tap_hears_the_exchange(16ms, 0s);
}

TEST(Tap, UsbLatencyOnThePtyStillDeliversEveryReplyWhole) {
  expect_tap_hears_the_exchange(0s, 16ms);
}

TEST(Tap, WhatIsWrittenIntoTheTapNeverReachesTheLine) {
  SimServerOptions o;
  o.pty = true;
  o.tap_link = tap_path("write");
  Twin twin(std::move(o));
  SerialLink tap(twin.server().tap()->client_path(), SerialOptions{.baud = 38400});
  tap.write(tap_read_state());         // a listener that transmits: discarded
  std::this_thread::sleep_for(100ms);  // (nothing to wait for: the absence of a reply)
  EXPECT_EQ(twin.server().stats().bytes_in, 0u);
  EXPECT_EQ(twin.server().stats().replies_sent, 0u);
}

}  // namespace
}  // namespace lec6::twin
