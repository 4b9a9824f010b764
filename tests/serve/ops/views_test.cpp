// What the daemon shows of an axis says how old each value is: after an
// outage the flags come back first, and the position shown with them is the
// one from before it — with its true age, never the fresh flags' age.
// A Line over the twin on a virtual clock.

#include "ops/views.hpp"

#include <gtest/gtest.h>

#include "lec6/client/rtu_master.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/twin/sim_link.hpp"

namespace lec6::serve {
namespace {

using namespace std::chrono_literals;

TEST(Views, AfterAnOutageThePositionShowsItsTrueAge) {
  VirtualClock clock{TimePoint{} + 1s};
  sim::Bus bus;
  bus.add(1, {}, clock.now());
  twin::SimLink link{bus, clock};
  LineOptions o;
  o.name = "line1";
  o.port = "sim";
  o.scheduler.axes = {{1, 100ms}};
  o.scheduler.probe_interval = 1s;
  Line line(
      o,
      [&] {
        Wire w;
        w.master = std::make_unique<client::RtuMaster>(link);
        return w;
      },
      clock);
  const auto run_until = [&](const std::function<bool()>& done, Duration limit) {
    const TimePoint end = clock.now() + limit;
    while (!done() && clock.now() < end) {
      if (line.run_once()) continue;
      const auto w = line.wake_at();
      clock.set(w && *w > clock.now() && *w < end ? *w : end);
    }
    return done();
  };
  LineConfig lc;
  lc.name = "line1";
  AxisConfig ac;
  ac.id = 1;
  ac.name = "axis1";
  const AxisRef axis{"axis1", 1, &line, &lc, &ac};

  ASSERT_TRUE(run_until([&] { return line.snapshot(1).state.has_value(); }, 1s));
  auto j = telemetry_json(axis, line.snapshot(1));
  EXPECT_LT(j["age_ms"].get<double>(), 150);
  EXPECT_LT(j["ages_ms"]["state"].get<double>(), 150);

  // Five seconds of lost replies: offline.
  auto faults = bus.faults();
  faults.drop = 1.0;
  bus.set_faults(faults);
  ASSERT_TRUE(run_until([&] { return line.health(1).offline; }, 5s));
  run_until([] { return false; }, 5s);
  faults.drop = 0;
  bus.set_faults(faults);
  // The probe answers (a flags read): online, fresh flags, the old position.
  ASSERT_TRUE(run_until([&] { return !line.health(1).offline; }, 3s));
  const AxisSnapshot s = line.snapshot(1);
  ASSERT_GT(s.flags_at, s.state_at) << "the state was read again already";
  j = telemetry_json(axis, s);
  EXPECT_TRUE(j["online"].get<bool>());
  EXPECT_LT(j["ages_ms"]["flags"].get<double>(), 100);
  EXPECT_GT(j["ages_ms"]["state"].get<double>(), 5000) << j.dump();
  EXPECT_GT(j["age_ms"].get<double>(), 5000) << "an old position presented as fresh: " << j.dump();
  // The next pass reads the state: fresh again.
  ASSERT_TRUE(run_until([&] { return line.snapshot(1).state_at > s.flags_at; }, 1s));
  j = telemetry_json(axis, line.snapshot(1));
  EXPECT_LT(j["age_ms"].get<double>(), 150);
}

}  // namespace
}  // namespace lec6::serve
