// lec doctor's probes on the virtual clock: each line fault the twin plays,
// alone and in combination, on a twin::VirtualLine, through the same probes
// `lec doctor` runs on a serial port (cli/doctor_probes.cpp) and the same
// judgement (client/doctor). Each case runs over several seeds (the noise,
// the collisions, the doctor's phase against the other master's period and
// the adapter's timer) and its verdict must hold in
// every one: on the virtual clock no host stalls a twin, so there is no
// "a loaded host? once more". A whole doctor run costs milliseconds of wall
// time here against 3-20 s on a pty (tests/integration/doctor_test.sh keeps
// what needs a real port: the port's baud setting, sysfs, a port held by
// lec serve, a gateway).

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "cli/doctor_probes.hpp"
#include "lec6/client/actuator.hpp"
#include "lec6/client/client.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/twin/virtual_line.hpp"
#include "sanitized.hpp"

namespace lec6::cli {
namespace {

namespace dx = client::doctor;
using std::chrono::milliseconds;
using std::chrono::seconds;

// One plant: the twins on their line, its faults, and what the user typed.
struct Plant {
  std::vector<uint8_t> ids{1};
  uint32_t baud = 38400;
  sim::Timing timing = sim::Timing::Real;
  Duration td = milliseconds(5);
  unsigned silent_interval_k = 1;
  sim::FaultConfig faults{};
  twin::VirtualLineOptions line{};
  // The user's options.
  bool echo_option = false;
  std::string id_range = "1-4";
  doctor_probes::Fix fix{};
  // Before the doctor: alarm 62 on this ID (a move past its stroke).
  std::optional<uint8_t> alarm_on{};
  // Ctrl-C after this much of the doctor's run (on the virtual clock).
  std::optional<Duration> interrupt_after{};
};

struct Seen {  // one doctor run
  dx::Observations obs;
  dx::Report report;
  std::string text;  // every finding, as `lec doctor` prints them (unwrapped)
  Duration took{};   // on the virtual clock
  bool has(const std::string& s) const { return text.find(s) != std::string::npos; }
};

std::vector<uint8_t> parse_range(const std::string& r) {  // "1-4"
  const auto dash = r.find('-');
  const int lo = std::stoi(r.substr(0, dash)), hi = std::stoi(r.substr(dash + 1));
  std::vector<uint8_t> ids;
  for (int id = lo; id <= hi; ++id) ids.push_back(static_cast<uint8_t>(id));
  return ids;
}

// Alarm 62 on `id`: serial on, servo on, home, then direct operation past the stroke.
void raise_alarm_62(twin::VirtualLine& line, const sim::Bus& bus, uint8_t id) {
  twin::PortOptions po;
  po.baud = bus.line().line.baud;
  po.backoff_seed = 1;
  auto port = twin::open_port_over(line.open(po.baud), po);
  client::Client c(port->master(), {.id = id, .retries = 3});
  client::Actuator axis(c);
  axis.set_serial_mode(true);
  axis.servo_on(axis.deadline_in(seconds(2)));
  axis.home(axis.deadline_in(seconds(60)));
  try {
    client::DirectMove past_the_stroke;
    past_the_stroke.position_001mm = 90000;
    axis.move(past_the_stroke, axis.deadline_in(seconds(10)));
  } catch (const Error&) {  // refused by the controller: alarm 62
  }
  ASSERT_THAT(axis.active_alarms(c.read_flags()), ::testing::Contains(62));
}

Seen doctor(const Plant& p, uint64_t seed) {
  sim::LineConfig lc;
  lc.line.baud = p.baud;
  lc.line.delay_td = p.td;
  lc.line.silent_interval_k = p.silent_interval_k;
  lc.timing = p.timing;
  sim::FaultConfig faults = p.faults;
  faults.seed = seed;
  VirtualClock clock{TimePoint{} + seconds(1)};
  sim::Bus bus(lc, faults);
  for (uint8_t id : p.ids) bus.add(id, {}, clock.now());
  twin::VirtualLineOptions lo = p.line;
  twin::VirtualLine line(bus, clock, lo);
  // The doctor comes at a phase of its own against the line's clocks (the
  // other master's period, the adapter's timer ticks), drawn from the seed:
  // 0-100 ms, a prime step apart.
  clock.advance(std::chrono::microseconds((seed * 7919) % 100000));
  if (p.alarm_on) raise_alarm_62(line, bus, *p.alarm_on);

  doctor_probes::ProbeSettings s;  // lec's defaults: 38400, Silent INT 1, Td 5 ms
  doctor_probes::ProbeLine pl;
  pl.open = [&](uint32_t baud, bool discard_echo) {
    twin::PortOptions po;
    po.baud = baud;
    po.silent_interval_k = s.silent_interval_k;
    po.delay_td = s.delay_td;
    po.timeout_margin = s.reply_margin;
    po.backoff_seed = static_cast<uint32_t>(seed);  // a seed replays, whatever ran before
    return twin::open_port_over(line.open(baud, discard_echo), po);
  };
  pl.clock = &clock;
  pl.wait = [&](Duration d) { clock.advance(d); };
  const TimePoint began = clock.now();
  if (p.interrupt_after) {
    pl.interrupted = [&clock, began, after = *p.interrupt_after] {
      return clock.now() - began >= after;
    };
  }

  Seen r;
  r.obs = doctor_probes::asked("line", p.id_range, p.echo_option, p.fix.on, s);
  const TimePoint start = began;
  doctor_probes::probe_line(pl, s, parse_range(p.id_range), p.fix, p.echo_option, r.obs);
  r.took = clock.now() - start;
  r.report = dx::diagnose(r.obs);
  for (const auto& f : r.report.findings) {
    r.text += std::string(dx::to_string(f.severity)) + " " + f.check + " " + f.saw + " -- " +
              f.means + (f.todo.empty() ? "" : ". Do: " + f.todo) + "\n";
  }
  return r;
}

// Seeds per case: enough to see a verdict that holds only now and then.
int seeds() {
  return lec6::testing::kSanitized ? 8 : 40;
}

// Runs the plant over the seeds; `check` asserts on each run.
template <typename Check>
void every_seed(const Plant& p, Check check) {
  for (int seed = 1; seed <= seeds(); ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const Seen r = doctor(p, static_cast<uint64_t>(seed));
    if (std::getenv("LEC6_DOCTOR_PRINT")) {  // what each run found, to look at
      std::printf("seed %d: %d burst exchanges, %.1f s (virtual)\n%s", seed, r.obs.burst.exchanges,
                  std::chrono::duration<double>(r.took).count(), r.text.c_str());
      for (const auto& c : r.obs.controllers)
        if (!c.read_error.empty())
          std::printf("  ID %d not read: %s\n", c.id, c.read_error.c_str());
    }
    check(r);
    if (::testing::Test::HasFailure()) {
      ADD_FAILURE() << r.text;
      return;
    }
  }
}

// The finding of `check` ("echo", "other-master"), if there is one.
const dx::Finding* finding(const Seen& r, const std::string& check) {
  for (const auto& f : r.report.findings)
    if (f.check == check) return &f;
  return nullptr;
}

// Every controller found was read (no "could not be read").
bool controllers_read(const Seen& r) {
  if (r.obs.controllers.empty()) return false;
  for (const auto& c : r.obs.controllers)
    if (!c.read_error.empty()) return false;
  return true;
}

bool only_info(const Seen& r) {
  for (const auto& f : r.report.findings)
    if (f.severity != dx::Severity::Info) return false;
  return true;
}

TEST(DoctorProbes, ACleanLineIsHealthyWithInformationOnly) {
  every_seed(Plant{}, [](const Seen& r) {
    EXPECT_EQ(r.report.health, dx::Health::Healthy);
    EXPECT_TRUE(only_info(r));
    EXPECT_TRUE(r.has("ID 1 at 38400"));
    EXPECT_TRUE(r.has("the line is clean"));
  });
}

// The integration case: IDs 1 and 3 at 57600 (not lec's default), ID 3 in
// alarm 62, the whole ID range asked.
Plant two_at_57600() {
  Plant p;
  p.ids = {1, 3};
  p.baud = 57600;
  p.alarm_on = 3;
  p.id_range = "1-32";
  return p;
}

TEST(DoctorProbes, TwoControllersAt57600WithAnAlarmAreFoundWithNoOptions) {
  every_seed(two_at_57600(), [](const Seen& r) {
    EXPECT_EQ(r.report.health, dx::Health::Degraded);
    EXPECT_TRUE(r.has("ID 1 and 3 at 57600; nothing at 38400, 9600, 19200"));
    EXPECT_TRUE(r.has("give --baud 57600"));
    EXPECT_TRUE(r.has("alarm 62"));
    EXPECT_TRUE(r.has("lec --port line --baud 57600 --id 3 reset"));
    EXPECT_TRUE(r.has("--id 1 serial on"));
  });
}

TEST(DoctorProbes, FixClearsTheAlarmAndLeavesSerialModeAloneUnlessTold) {
  Plant p = two_at_57600();
  p.fix.on = true;
  const Seen r = doctor(p, 1);
  EXPECT_TRUE(r.has("alarm 62 cleared (RESET)")) << r.text;
  EXPECT_FALSE(r.has("serial mode on (Y30)")) << r.text;
  EXPECT_TRUE(r.has("lec doctor --fix --serial-ids 1")) << r.text;
  p.fix.serial_ids = {1};
  const Seen told = doctor(p, 1);
  EXPECT_TRUE(told.has("serial mode on (Y30)")) << told.text;
}

TEST(DoctorProbes, AnEchoingAdapterIsBrokenUntilEchoIsGivenAndTheFixIsVerified) {
  Plant p;
  p.line.echo_adapter = true;
  every_seed(p, [](const Seen& r) {
    EXPECT_EQ(r.report.health, dx::Health::Broken);
    EXPECT_TRUE(r.has("add --echo to every lec command (verified"));
    EXPECT_TRUE(controllers_read(r)) << "read with the echo discarded";
  });
  p.echo_option = true;
  every_seed(p, [](const Seen& r) {
    EXPECT_EQ(r.report.health, dx::Health::Healthy);
    EXPECT_TRUE(controllers_read(r));
  });
}

TEST(DoctorProbes, NoiseOnTheLineGivesTheCausesInOrder) {
  Plant p;
  p.faults.noise_rate = 250;
  every_seed(p, [](const Seen& r) {
    EXPECT_NE(r.report.health, dx::Health::Healthy);
    EXPECT_TRUE(r.has("likely causes, in order: termination"));
  });
}

TEST(DoctorProbes, TwoControllersOnOneIdAreNamed) {
  Plant p;
  p.ids = {1, 2};
  p.faults.duplicate_ids = {2};
  every_seed(p, [](const Seen& r) {
    EXPECT_EQ(r.report.health, dx::Health::Broken);
    EXPECT_TRUE(r.has("two controllers answer ID 2"));
  });
}

TEST(DoctorProbes, AnotherMasterPollingTheLineIsNamed) {
  Plant p;
  p.line.other_master_period = milliseconds(50);  // lec sim --other-master 20
  every_seed(p, [](const Seen& r) {
    EXPECT_EQ(r.report.health, dx::Health::Broken);
    ASSERT_NE(finding(r, "other-master"), nullptr);
    EXPECT_EQ(finding(r, "other-master")->severity, dx::Severity::Error);
    EXPECT_TRUE(r.has("another master polls this line"));
    // Its query to ID 1 is ours byte for byte: no echo, and its frames in
    // our windows are no second controller on ID 1 (a reviewer's finding).
    EXPECT_EQ(finding(r, "echo"), nullptr);
    EXPECT_EQ(finding(r, "duplicate-id"), nullptr);
    // Read without echo discard: when the other master's traffic takes
    // every attempt (it may, at 20/s), the report says so, never "echo".
    for (const auto& c : r.obs.controllers)
      EXPECT_THAT(c.read_error, ::testing::Not(::testing::HasSubstr("echo")));
  });
}

TEST(DoctorProbes, ALongerTdIsInferredAndNamed) {
  Plant p;
  p.td = milliseconds(20);
  every_seed(p, [](const Seen& r) {
    EXPECT_EQ(r.report.health, dx::Health::Degraded);
    EXPECT_TRUE(r.has("--td 20ms"));
  });
}

TEST(DoctorProbes, UsbLatencyLumpsAreSeenInTheRoundTripsWithoutSysfs) {
  Plant p;
  p.line.usb_latency = milliseconds(16);
  every_seed(p, [](const Seen& r) {
    EXPECT_TRUE(r.has("a USB adapter's latency timer"));
    EXPECT_TRUE(r.has("set the adapter's latency timer to 1 ms"));
  });
}

TEST(DoctorProbes, APortNoWirePacesIsHealthyAndItsTimingIsNotJudged) {
  Plant p;
  p.timing = sim::Timing::Fast;
  every_seed(p, [](const Seen& r) {
    EXPECT_EQ(r.report.health, dx::Health::Healthy);
    EXPECT_TRUE(r.has("no RS485 line paces this port"));
    EXPECT_TRUE(r.has("the line is clean"));
  });
}

TEST(DoctorProbes, ALongerSilentIntervalIsNamed) {
  Plant p;
  p.silent_interval_k = 20;  // Ts = 70 chars, 18 ms at 38400; lec assumes 1
  every_seed(p, [](const Seen& r) {
    EXPECT_EQ(r.report.health, dx::Health::Degraded);
    EXPECT_TRUE(r.has("Silent INT is"));
  });
}

TEST(DoctorProbes, EchoAndAWrongBaudAreBothNamed) {
  Plant p;
  p.ids = {2};
  p.baud = 19200;
  p.line.echo_adapter = true;
  every_seed(p, [](const Seen& r) {
    EXPECT_EQ(r.report.health, dx::Health::Broken);
    EXPECT_TRUE(r.has("ID 2 at 19200"));
    EXPECT_TRUE(r.has("add --echo"));
  });
}

TEST(DoctorProbes, AnotherMasterAndALongTdAreBrokenWithTheMasterNamed) {
  Plant p;
  p.line.other_master_period = milliseconds(100);
  p.td = milliseconds(20);
  every_seed(p, [](const Seen& r) {
    EXPECT_EQ(r.report.health, dx::Health::Broken);
    ASSERT_NE(finding(r, "other-master"), nullptr);
    EXPECT_EQ(finding(r, "other-master")->severity, dx::Severity::Error);
    EXPECT_TRUE(r.has("another master polls this line"));
    EXPECT_EQ(finding(r, "echo"), nullptr);
  });
}

TEST(DoctorProbes, ADuplicateIdAt115200WithAnAlarmOnTheOtherIdIsNamedWithBoth) {
  Plant p;
  p.ids = {1, 4};
  p.faults.duplicate_ids = {4};
  p.baud = 115200;
  p.alarm_on = 1;
  every_seed(p, [](const Seen& r) {
    EXPECT_EQ(r.report.health, dx::Health::Broken);
    EXPECT_TRUE(r.has("at 115200"));
    EXPECT_TRUE(r.has("two controllers answer ID 4"));
    EXPECT_TRUE(r.has("alarm 62"));
  });
}

// Replies whole but after their window (a slow converter, a busy host): the
// reply window is what to change, not the cabling.
TEST(DoctorProbes, LateButWholeRepliesPointAtTheReplyWindowNotTheCabling) {
  Plant p;
  p.faults.delay = 0.1;
  p.faults.extra_delay = milliseconds(70);  // past the 50 ms margin, within one more
  every_seed(p, [](const Seen& r) {
    EXPECT_TRUE(r.has("ID 1 at 38400"));
    ASSERT_NE(finding(r, "line-quality"), nullptr);
    EXPECT_THAT(finding(r, "line-quality")->saw, ::testing::HasSubstr("whole but late"));
    EXPECT_THAT(finding(r, "line-quality")->todo, ::testing::HasSubstr("--reply-margin"));
    EXPECT_THAT(finding(r, "line-quality")->todo,
                ::testing::Not(::testing::HasSubstr("termination")));
  });
}

// Ctrl-C: the probes end at their next exchange, whatever they were doing.
TEST(DoctorProbes, CtrlCEndsTheProbesAtOnce) {
  for (const Duration after :
       std::vector<Duration>{milliseconds(100), milliseconds(700), seconds(2), seconds(5)}) {
    Plant p = two_at_57600();
    p.interrupt_after = after;
    const Seen r = doctor(p, 1);
    // The first listen for another master (0.5 s) is not cut short.
    EXPECT_LT(r.took, std::max(after, doctor_probes::kListen) + milliseconds(200))
        << "interrupted after " << after.count() << " ns";
  }
}

TEST(DoctorProbes, ADeadLineIsBrokenWithTheChecklistWithinTheBudget) {
  Plant p;
  p.faults.drop = 1.0;
  p.id_range = "1-32";
  every_seed(p, [](const Seen& r) {
    EXPECT_EQ(r.report.health, dx::Health::Broken);
    EXPECT_TRUE(r.has("nothing answers at any baud"));
    EXPECT_TRUE(r.has("A/B (+/-) are not swapped"));
    EXPECT_LT(r.took, seconds(30));
  });
}

}  // namespace
}  // namespace lec6::cli
