#include "lec6/client/actuator.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sim_fixture.hpp"

namespace lec6::client {
namespace {

using ::testing::HasSubstr;
using testing::SimFixture;

TEST(Actuator, OperationsNeedSerialModeAndSayHowToGetIt) {
  SimFixture f;
  try {
    f.axis->servo_on(f.axis->deadline_in(std::chrono::seconds(1)));
    FAIL();
  } catch (const InvalidRequest& e) {
    EXPECT_THAT(e.what(), HasSubstr("lec serial on"));
  }
}

TEST(Actuator, HomingNeedsServo) {
  SimFixture f;
  f.axis->set_serial_mode(true);
  EXPECT_THROW(f.axis->home(f.axis->deadline_in(std::chrono::seconds(1))), InvalidRequest);
}

TEST(Actuator, HomeClearsSetupAfterwards) {
  SimFixture f;
  f.prepare();
  EXPECT_FALSE(f.client->read_controls().test(lec::Coil::SETUP));
  EXPECT_TRUE(f.client->read_flags().seton());
  EXPECT_EQ(f.client->read_state().position_001mm, 0);
}

TEST(Actuator, MoveBeyondTheStrokeRaisesTheAlarmWithItsMeaning) {
  SimFixture f;
  f.prepare();
  DirectMove m;
  m.position_001mm = 1'000'000;  // 10 m
  try {
    f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(5)));
    FAIL();
  } catch (const AlarmError& e) {
    EXPECT_THAT(e.codes(), ::testing::ElementsAre(lec::alarm::kDirectBeyondStroke));
    EXPECT_THAT(e.what(), HasSubstr("beyond the stroke"));
    EXPECT_THAT(e.what(), HasSubstr("lec reset"));
  }
  EXPECT_EQ(f.client->read_state().position_001mm, 0);  // nothing moved
  EXPECT_TRUE(f.axis->reset_alarms().empty());
  EXPECT_FALSE(f.client->read_flags().alarm());
}

TEST(Actuator, BlankStepIsRefusedBeforeDrive) {
  SimFixture f;
  f.prepare();
  EXPECT_THROW(f.axis->run_step(9, f.axis->deadline_in(std::chrono::seconds(5))), InvalidRequest);
}

TEST(Actuator, CancelStopsTheAxisBeforeReturning) {
  SimFixture f;
  f.prepare();
  DirectMove m;
  m.position_001mm = 30000;
  m.speed_mm_s = 100;
  int polls = 0;
  WaitOptions w;
  w.cancel = [&] { return ++polls > 5; };
  EXPECT_THROW(f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(10)), w), Cancelled);
  const auto flags = f.client->read_flags();
  EXPECT_FALSE(flags.busy());
  const auto pos = f.client->read_state().position_001mm;
  EXPECT_GT(pos, 0);
  EXPECT_LT(pos, 30000);
}

TEST(Actuator, DeadlineIsEnforced) {
  SimFixture f;
  f.prepare();
  DirectMove m;
  m.position_001mm = 30000;
  m.speed_mm_s = 10;  // 30 s
  EXPECT_THROW(f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(1))), DeadlineError);
}

TEST(Actuator, ProgressReportsMotion) {
  SimFixture f;
  f.prepare();
  DirectMove m;
  m.position_001mm = 20000;
  std::vector<int32_t> positions;
  WaitOptions w;
  w.progress = [&](const Progress& p) { positions.push_back(p.state.position_001mm); };
  auto r = f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(10)), w);
  EXPECT_TRUE(r.in_position);
  ASSERT_GT(positions.size(), 5u);
  EXPECT_TRUE(std::is_sorted(positions.begin(), positions.end()));
  EXPECT_EQ(positions.back(), 20000);
}

TEST(Actuator, JogMovesWhileHeldAndStops) {
  SimFixture f;
  f.prepare();
  auto r = f.axis->jog(true, f.axis->deadline_in(std::chrono::seconds(1)),
                       f.axis->deadline_in(std::chrono::seconds(5)));
  EXPECT_FALSE(r.flags.busy());
  EXPECT_GT(r.state.position_001mm, 3000);  // ~50 mm/s for 1 s
  EXPECT_LT(r.state.position_001mm, 6000);
  EXPECT_FALSE(f.client->read_controls().test(lec::Coil::JOG_PLUS));
}

TEST(Actuator, MergeKeepsControllerDataAndDefaultsWhenBlank) {
  DirectMove m;
  m.position_001mm = 500;
  const auto d = merge_direct(lec::StepData{}, m);
  EXPECT_TRUE(lec::validate(d).empty());
  EXPECT_EQ(d.position_001mm, 500);
  EXPECT_EQ(d.speed_mm_s, default_direct_data().speed_mm_s);
  auto held = default_direct_data();
  held.speed_mm_s = 321;
  EXPECT_EQ(merge_direct(held, m).speed_mm_s, 321);
}

}  // namespace
}  // namespace lec6::client
