// LineMaster, the Master lec serve's own operations (HTTP, MQTT, Sparkplug)
// talk through: a Client resends a write whose reply was lost as a new job,
// and that resend must be superseded by a stop accepted after the first
// attempt, as the first attempt would have been (scheduler.cpp, "A stop
// supersedes"; a reviewer's finding). A Line on the in-process twin, on its
// own thread and the wall clock (fast timing: the waits are the lost replies'
// windows, ~70 ms each).

#include "line/line_master.hpp"

#include <gtest/gtest.h>

#include <future>
#include <thread>

#include "lec6/client/client.hpp"
#include "lec6/client/rtu_master.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/twin/sim_link.hpp"

namespace lec6::serve {
namespace {

using namespace std::chrono_literals;
using lec::Coil;

struct LiveLine {
  LiveLine() {
    sim::LineConfig lc;
    lc.timing = sim::Timing::Fast;
    bus = std::make_unique<sim::Bus>(lc);
    bus->add(1, {}, clock.now());
    link = std::make_unique<twin::SimLink>(*bus, clock);
    LineOptions o;
    o.name = "line1";
    o.port = "sim";
    o.scheduler.axes.push_back({1, Duration{}});  // no telemetry: only the test's jobs
    line = std::make_unique<Line>(
        o,
        [this] {
          Wire w;
          w.master = std::make_unique<client::RtuMaster>(*link);
          return w;
        },
        clock);
    line->start();
    on_line([this] {
      for (const Coil c : {Coil::SerialMode, Coil::SVON})
        bus->find(1)->handle(modbus::WriteCoilRequest{lec::address(c), modbus::kCoilOn},
                             clock.now());
    });
  }
  ~LiveLine() { line->stop(); }
  // Runs `task` on the line's thread (the twin is that thread's) and waits.
  void on_line(std::function<void()> task) {
    auto done = std::make_shared<std::promise<void>>();
    auto f = done->get_future();
    line->post([task = std::move(task), done] {
      task();
      done->set_value();
    });
    f.get();
  }
  void drop_replies(bool on) {
    on_line([this, on] {
      sim::FaultConfig f;
      f.drop = on ? 1.0 : 0.0;
      bus->set_faults(f);
    });
  }
  // A stop from another front-end (a PLC's RESET), accepted by the line.
  void stop_from_elsewhere() {
    auto done = std::make_shared<std::promise<JobResult>>();
    auto f = done->get_future();
    Job j;
    j.priority = Priority::Emergency;
    j.frame = {1, modbus::WriteCoilRequest{lec::address(Coil::RESET), modbus::kCoilOn}};
    j.done = [done](const JobResult& r) { done->set_value(r); };
    line->submit(std::move(j));
    EXPECT_EQ(f.get().failure, Failure::None);
  }

  SteadyClock clock;
  std::unique_ptr<sim::Bus> bus;
  std::unique_ptr<twin::SimLink> link;
  std::unique_ptr<Line> line;
};

TEST(LineMaster, AResendOfALostStartAfterAStopIsSupersededEvenWithReadsBetween) {
  LiveLine l;
  LineMaster m(*l.line, Priority::Command, Priority::Command);
  client::ClientOptions o;
  o.retries = 0;  // the test resends by hand, as an INC move does after a read
  client::Client c(m, o);
  l.drop_replies(true);
  EXPECT_THROW(c.write_coil(Coil::DRIVE, true), client::TransportError);  // its reply is lost
  l.drop_replies(false);
  l.stop_from_elsewhere();
  c.read_state();  // an INC move reads the position before it resends (actuator_move.cpp)
  EXPECT_THROW(c.write_coil(Coil::DRIVE, true), client::Superseded);
}

TEST(LineMaster, WithoutAStopTheResendIsCarriedOut) {
  LiveLine l;
  LineMaster m(*l.line, Priority::Command, Priority::Command);
  client::ClientOptions o;
  o.retries = 0;
  client::Client c(m, o);
  l.drop_replies(true);
  EXPECT_THROW(c.write_coil(Coil::DRIVE, true), client::TransportError);
  l.drop_replies(false);
  c.read_state();
  EXPECT_NO_THROW(c.write_coil(Coil::DRIVE, true));
  c.write_coil(Coil::DRIVE, false);
  // A new operation's start after the stop (a LineMaster of its own) is a new
  // command: carried out.
  l.stop_from_elsewhere();
  LineMaster next(*l.line, Priority::Command, Priority::Command);
  client::Client c2(next, o);
  EXPECT_NO_THROW(c2.write_coil(Coil::DRIVE, true));
}

// Issue 32 (wire dating): the times a LineMaster reports are the exchange's
// on the line, not the wait in the queue before it nor the hop back to the
// caller's thread. The line's thread is held 200 ms (a transaction of
// another client, as it were) when the read is submitted.
TEST(LineMaster, ItsWireTimesAreTheExchangesNotTheQueuesWait) {
  LiveLine l;
  LineMaster m(*l.line, Priority::Command, Priority::Command);
  const auto before = l.clock.now();
  std::promise<void> holding;
  auto held = holding.get_future();
  l.line->post([&holding] {  // the scenario: a line busy when the read comes
    holding.set_value();
    std::this_thread::sleep_for(200ms);
  });
  held.wait();  // the line's thread is in it: the read waits in the queue
  const auto reply = m.exchange({1, modbus::ReadRegistersRequest{lec::kStateData, 7}});
  const auto after = l.clock.now();
  EXPECT_TRUE(std::holds_alternative<modbus::ReadRegistersResponse>(reply.pdu));
  const auto w = m.last_wire_times();
  ASSERT_TRUE(w);
  EXPECT_GE(w->sent - before, 190ms) << "dated at the submit, not on the wire";
  EXPECT_LE(w->sent, w->replied);
  EXPECT_LE(w->replied, after);
  EXPECT_LT(w->replied - w->sent, 100ms);  // the in-process twin answers at once
  EXPECT_EQ(m.last_round_trip(), w->replied - w->sent);
}

}  // namespace
}  // namespace lec6::serve
