// Hostile bytes against what reads a host's payloads on the MQTT client's
// thread (payload.hpp: visit/decode_metrics_leniently, decode; session.hpp:
// stop_request, received): random bytes and mutations of valid DCMDs, NCMDs
// and STATEs must never crash, hang or throw. A fixed seed (reproducible);
// LEC6_FUZZ_ITERATIONS runs more.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <random>

#include "sparkplug/payload.hpp"
#include "sparkplug/session.hpp"

namespace lec6::serve::sparkplug {
namespace payload_fuzz {

SessionConfig fuzz_config() {
  SessionConfig c;
  c.group_id = "plant";
  c.edge_node_id = "box7";
  c.primary_host_id = "scada";
  c.node_metrics = {{"Properties/Version", DataType::String, false}};
  for (const char* id : {"axis1", "axis2"}) {
    c.devices.push_back({id,
                         {{"Position mm", DataType::Double, false},
                          {"Command/Stop", DataType::Boolean, true},
                          {"Command/Home", DataType::Boolean, true},
                          {"Command/Run Step", DataType::Int32, true},
                          {"Command/Move/Position mm", DataType::Double, true}}});
  }
  return c;
}

std::vector<std::string> seeds(const EdgeSession& s) {
  std::vector<std::string> out;
  Payload p;
  p.timestamp_ms = 1700000000000;
  Metric stop;
  stop.alias = s.alias_of(0, 1);
  stop.datatype = DataType::Boolean;
  stop.value = true;
  Metric step;
  step.name = "Command/Run Step";
  step.datatype = DataType::Int32;
  step.value = int64_t{3};
  Metric pos;
  pos.alias = s.alias_of(0, 4);
  pos.datatype = DataType::Double;
  pos.value = 12.5;
  Metric text;
  text.name = "Command/Home";
  text.datatype = DataType::String;
  text.value = std::string(300, 'x');
  p.metrics = {step, pos};
  out.push_back(encode(p));
  p.metrics = {pos, stop, text};
  out.push_back(encode(p));
  Metric rebirth;
  rebirth.name = std::string(kRebirth);
  rebirth.datatype = DataType::Boolean;
  rebirth.value = true;
  p.metrics = {rebirth};
  out.push_back(encode(p));
  out.push_back(R"({"online":true,"timestamp":1700000000000})");
  return out;
}

std::string mutate(std::string b, std::mt19937_64& rng) {
  std::uniform_int_distribution<int> byte(0, 255);
  const int edits = 1 + static_cast<int>(rng() % 8);
  for (int e = 0; e < edits; ++e) {
    const std::size_t at = b.empty() ? 0 : rng() % b.size();
    switch (rng() % 6) {
      case 0:
        if (!b.empty()) b[at] = static_cast<char>(byte(rng));
        break;
      case 1:
        b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), static_cast<char>(byte(rng)));
        break;
      case 2:
        if (!b.empty()) b.erase(at, 1 + rng() % 4);
        break;
      case 3:
        b.resize(at);  // cut short
        break;
      case 4: {  // a huge varint length where one was
        const std::string big = "\xff\xff\xff\xff\x0f";
        b.insert(at, big);
        break;
      }
      default:
        if (!b.empty()) b += b.substr(at, 1 + rng() % 16);  // repeated fragments
        break;
    }
  }
  return b;
}

TEST(SparkplugPayloadFuzz, HostileBytesNeverCrashHangOrThrow) {
  EdgeSession s(fuzz_config(), std::nullopt);
  s.will();
  (void)s.connected(1000);
  (void)s.received("spBv1.0/STATE/scada", R"({"online":true,"timestamp":1})", true, 1001);
  ASSERT_TRUE(s.born());
  const auto base = seeds(s);
  const char* env = std::getenv("LEC6_FUZZ_ITERATIONS");
  const long iterations = env ? std::atol(env) : 20000;
  std::mt19937_64 rng(35);
  const std::vector<std::string> topics = {"spBv1.0/plant/DCMD/box7/axis1",
                                           "spBv1.0/plant/DCMD/box7/axis2",
                                           "spBv1.0/plant/NCMD/box7", "spBv1.0/STATE/scada"};
  const auto t0 = std::chrono::steady_clock::now();
  std::size_t stops = 0, commands = 0;
  for (long i = 0; i < iterations; ++i) {
    std::string bytes;
    if (i % 4 == 0) {
      bytes.resize(rng() % 256);
      for (char& c : bytes) c = static_cast<char>(rng());
    } else {
      bytes = mutate(base[rng() % base.size()], rng);
    }
    const std::string& topic = topics[rng() % topics.size()];
    ASSERT_NO_THROW({
      (void)decode_metrics_leniently(bytes);
      (void)decode(bytes);
      if (s.stop_request(topic, bytes, false)) ++stops;
      auto r = s.received(topic, bytes, (i % 7) == 0, 2000 + static_cast<uint64_t>(i));
      if (r.command) ++commands;
    }) << "iteration "
       << i;
    if (!s.born()) {  // a mutated STATE offline: connect again, as the node does
      s.will();
      (void)s.connected(3000);
      (void)s.received("spBv1.0/STATE/scada", R"({"online":true,"timestamp":18446744073709551615})",
                       true, 3001);
    }
  }
  const double s_taken =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("# %ld hostile payloads in %.2f s: %zu stops found, %zu commands\n", iterations,
              s_taken, stops, commands);
  EXPECT_LT(s_taken, 60.0);
}

// A payload made only of empty metrics: two bytes each (field 2, length 0).
std::string empty_metrics(std::size_t bytes) {
  std::string b;
  b.reserve(bytes);
  while (b.size() + 2 <= bytes) b += std::string("\x12\x00", 2);
  return b;
}

// A stop is found "the moment its message arrives" on the MQTT client's
// thread (docs/sparkplug.md). That thread runs stop_request() on every DCMD
// before it: it decoded every metric of a DCMD into a vector before looking,
// ~70x the DCMD's size in memory, and a stop behind a 16 MB DCMD waited 36 s
// (mosquitto's default message_size_limit is the protocol's 256 MB). Now a
// command over kMaxCommandBytes is refused unread, and the walk stops at the
// first stop.
TEST(SparkplugPayloadFuzz, ABigDcmdDoesNotHoldTheStopBehindIt) {
  EdgeSession s(fuzz_config(), std::nullopt);
  const std::string topic = "spBv1.0/plant/DCMD/box7/axis1";
  // 1 MB: refused unread, at once, whatever it holds.
  const std::string big = empty_metrics(1u << 20);
  // Each time is the least of five runs: the work, not a loaded host's worst
  // moment (one run under the sanitizers beside three other tests took 59 ms
  // where it takes 20). The slow walk this replaced took seconds every run.
  auto least_s = [](auto&& run) {
    double least = 1e9;
    for (int i = 0; i < 5; ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      run();
      least = std::min(
          least, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    return least;
  };
  EXPECT_FALSE(s.stop_request(topic, big, false));
  const auto r = s.received(topic, big, false, 0);
  ASSERT_TRUE(r.refused);
  EXPECT_NE(r.refused->why.find("bytes is refused unread"), std::string::npos) << r.refused->why;
  const double big_s = least_s([&] {
    EXPECT_FALSE(s.stop_request(topic, big, false));
    EXPECT_TRUE(s.received(topic, big, false, 0).refused);
  });
  EXPECT_LT(big_s, 0.05) << "a stop behind this one DCMD waits as long";
  // The largest a command may be, its stop last: found, and quickly.
  Payload stop;
  Metric m;
  m.alias = s.alias_of(0, 1);  // Command/Stop
  m.datatype = DataType::Boolean;
  m.value = true;
  stop.metrics.push_back(m);
  const std::string tail = encode(stop);
  const std::string most = empty_metrics(kMaxCommandBytes - tail.size()) + tail;
  ASSERT_LE(most.size(), kMaxCommandBytes);
  const double most_s = least_s(
      [&] { EXPECT_EQ(s.stop_request(topic, most, false), std::optional<std::size_t>(0)); });
  std::printf("# a %zu-byte DCMD with its stop last: found in %.2f ms\n", most.size(),
              most_s * 1e3);
  EXPECT_LT(most_s, 0.05);
}

}  // namespace payload_fuzz
}  // namespace lec6::serve::sparkplug
