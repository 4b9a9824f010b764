// The follower (client/follower.hpp) on the twin, on the virtual clock: a
// HOLD another master sets ends the following within `check_every`
// setpoints (issue 31 rule 6: a stop ends what moves), and following alone
// is never taken for one.

#include "lec6/client/follower.hpp"

#include <gtest/gtest.h>

#include "lec6/lec/memory_map.hpp"
#include "sim_fixture.hpp"

namespace lec6::client {
// Named: the unity build joins this file with others of the client tests.
namespace follower_testing {

using lec::Coil;
using testing::SimFixture;

FollowOptions every(unsigned n) {
  FollowOptions o;
  o.move.speed_mm_s = 200;
  o.check_every = n;
  return o;
}

// Another master on the same line writes a coil (the twin's controller
// hears it as it would a frame from an HMI).
void another_master_writes(SimFixture& f, Coil c, bool on) {
  f.bus.find(1)->handle(
      modbus::WriteCoilRequest{lec::address(c), on ? modbus::kCoilOn : modbus::kCoilOff},
      f.clock.now());
}

TEST(Follower, FollowingAloneIsNeverTakenForAStop) {
  SimFixture f;
  f.prepare();
  Follower fl(*f.axis, every(2));
  for (int i = 0; i < 40; ++i) {
    fl.apply(10000 + i * 100);
    ASSERT_FALSE(fl.stopped_elsewhere()) << "setpoint " << i;
  }
  fl.check();
  EXPECT_FALSE(fl.stopped_elsewhere());
  EXPECT_GT(fl.checks(), 0u);
}

TEST(Follower, AHoldFromAnotherMasterEndsTheFollowingWithinCheckEverySetpoints) {
  for (const Coil c : {Coil::HOLD, Coil::RESET}) {
    SimFixture f;
    f.prepare();
    Follower fl(*f.axis, every(4));
    for (int i = 0; i < 6; ++i) fl.apply(10000 + i * 100);
    another_master_writes(f, c, true);
    int applied_after = 0;
    while (!fl.stopped_elsewhere() && applied_after < 10) {
      fl.apply(11000 + applied_after * 100);
      ++applied_after;
    }
    EXPECT_TRUE(fl.stopped_elsewhere()) << "coil " << static_cast<int>(c);
    EXPECT_LE(applied_after, 4) << "coil " << static_cast<int>(c);
    EXPECT_TRUE(fl.last_controls().test(c));
  }
}

TEST(Follower, AnIdleCheckSeesTheHoldToo) {
  SimFixture f;
  f.prepare();
  Follower fl(*f.axis, every(8));
  fl.apply(15000);
  another_master_writes(f, Coil::HOLD, true);
  fl.check();  // no new setpoint: lec follow looks at the axis
  EXPECT_TRUE(fl.stopped_elsewhere());
}

}  // namespace follower_testing
}  // namespace lec6::client
