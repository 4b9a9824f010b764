// A Line over the twin on a virtual clock: real frames, the manual's timing,
// no wall time. The twin holds IDs 1–3; ID 9 is configured but absent.

#include "line/line.hpp"

#include <gtest/gtest.h>

#include "lec6/client/rtu_master.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/twin/sim_link.hpp"

namespace lec6::serve {
namespace {

using namespace std::chrono_literals;

struct Rig {
  explicit Rig(std::vector<uint8_t> configured, Duration period = 50ms) {
    for (uint8_t id : {1, 2, 3}) bus.add(id, {}, clock.now());
    LineOptions o;
    o.name = "line1";
    o.port = "sim";
    for (uint8_t id : configured) o.scheduler.axes.push_back({id, period});
    line = std::make_unique<Line>(
        o,
        [this] {
          Wire w;
          w.master = std::make_unique<client::RtuMaster>(link);
          return w;
        },
        clock);
    line->add_observer([this](const TelemetryEvent& e, const AxisSnapshot&) {
      if (e.block == Block::State) ++samples[e.id];
    });
  }
  void run_for(Duration d) {
    const TimePoint end = clock.now() + d;
    while (clock.now() < end) {
      if (line->run_once()) continue;
      const auto w = line->wake_at();
      clock.set(w && *w > clock.now() && *w < end ? *w : end);
    }
  }
  VirtualClock clock{TimePoint{} + 1s};
  sim::Bus bus;
  twin::SimLink link{bus, clock};
  std::unique_ptr<Line> line;
  std::map<uint8_t, int> samples;
};

TEST(Line, ADeadControllerCostsTheOthersLessThanTenPercentOfTheirTelemetry) {
  Rig baseline({1, 2, 3}, 20ms);  // more than the line can carry: it runs flat out
  baseline.run_for(60s);
  Rig with_dead({1, 2, 3, 9}, 20ms);
  with_dead.run_for(60s);
  EXPECT_TRUE(with_dead.line->health(9).offline);
  for (uint8_t id : {1, 2, 3}) {
    const double ratio = static_cast<double>(with_dead.samples[id]) / baseline.samples[id];
    EXPECT_GE(ratio, 0.90) << "ID " << int(id) << ": " << with_dead.samples[id] << " vs "
                           << baseline.samples[id];
    EXPECT_GT(baseline.samples[id], 500) << int(id);  // ~9 Hz each: the line is full
  }
  EXPECT_EQ(with_dead.samples[9], 0);
}

TEST(Line, StopAnswersQueuedJobsAndLaterOnes) {
  Rig rig({1});
  std::vector<Failure> got;
  for (int i = 0; i < 3; ++i) {
    Job j;
    j.frame = {1, modbus::ReadRegistersRequest{0x9000, 7}};
    j.done = [&](const JobResult& r) { got.push_back(r.failure); };
    rig.line->submit(std::move(j));
  }
  rig.line->run_once();  // one on the wire, answered
  rig.line->stop();
  Job late;
  late.frame = {1, modbus::ReadRegistersRequest{0x9000, 7}};
  late.done = [&](const JobResult& r) { got.push_back(r.failure); };
  rig.line->submit(std::move(late));
  ASSERT_EQ(got.size(), 4u);
  EXPECT_EQ(got[0], Failure::None);
  EXPECT_EQ(got[1], Failure::ShuttingDown);
  EXPECT_EQ(got[3], Failure::ShuttingDown);
}

// Two clients read the same block at once: the first goes to the wire, the
// second is answered from the cache when its turn comes, and delivered then,
// even with nothing else on the line (no telemetry) to carry it out. (The
// line simulation found it: the answer waited for the next exchange, here
// forever.)
TEST(Line, AReadAnsweredFromTheCacheAtItsTurnIsDeliveredAtOnce) {
  Rig rig({1}, Duration{});  // no telemetry
  std::vector<bool> from_cache;
  for (JobSource source : {JobSource{100}, JobSource{101}}) {
    Job j;
    j.source = source;
    j.max_cache_age = 1s;
    j.frame = {1, modbus::ReadRegistersRequest{0x9000, 7}};
    j.done = [&](const JobResult& r) { from_cache.push_back(r.from_cache); };
    rig.line->submit(std::move(j));
  }
  rig.run_for(5s);
  ASSERT_EQ(from_cache.size(), 2u);
  EXPECT_FALSE(from_cache[0]);
  EXPECT_TRUE(from_cache[1]);
}

TEST(Line, TelemetryFillsTheCacheTheApiReads) {
  Rig rig({1, 2}, 20ms);  // a full line: background reads still get their turn
  rig.run_for(2s);
  const auto s = rig.line->snapshot(2);
  ASSERT_TRUE(s.flags && s.state && s.controls && s.alarms);
  EXPECT_FALSE(s.flags->svre());
  EXPECT_FALSE(s.controls->serial_mode);
  EXPECT_LT(*rig.line->age(2, Block::State), 100ms);
}

}  // namespace
}  // namespace lec6::serve
