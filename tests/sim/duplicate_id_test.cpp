// Two controllers set to one ID (FaultConfig::duplicate_ids): both answer,
// and about `collision` of the replies collide: the ID byte intact, the CRC
// failing. Other IDs are untouched. Virtual time.

#include <gtest/gtest.h>

#include "lec6/modbus/crc.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/sim/bus.hpp"

namespace lec6::sim {
namespace {

modbus::Bytes read_state(uint8_t id) {
  return *modbus::encode_request({id, modbus::ReadRegistersRequest{0x9000, 7}});
}

struct Tally {
  int replies = 0;
  int garbled = 0;
};

Tally poll(Bus& bus, uint8_t id, int n, TimePoint& t) {
  Tally out;
  for (int i = 0; i < n; ++i) {
    const auto r = transact(bus, read_state(id), t);
    t += std::chrono::milliseconds(50);
    if (!r) continue;
    ++out.replies;
    EXPECT_EQ(r->bytes.at(0), id);  // the ID byte survives a collision
    if (!modbus::crc_ok(r->bytes)) ++out.garbled;
  }
  return out;
}

TEST(DuplicateId, AboutHalfTheRepliesCollideOnThatIdOnly) {
  FaultConfig f;
  f.duplicate_ids = {2};
  f.seed = 3;
  Bus bus({}, f);
  bus.add(1);
  bus.add(2);
  TimePoint t = TimePoint{} + std::chrono::seconds(1);
  const Tally one = poll(bus, 1, 200, t);
  const Tally two = poll(bus, 2, 200, t);
  EXPECT_EQ(one.replies, 200);
  EXPECT_EQ(one.garbled, 0);
  EXPECT_EQ(two.replies, 200);
  EXPECT_GT(two.garbled, 60);   // 0.5 expected: 100 +- a wide margin
  EXPECT_LT(two.garbled, 140);
  EXPECT_EQ(bus.stats().collisions, static_cast<uint64_t>(two.garbled));
}

TEST(DuplicateId, CollisionOneGarblesEveryReply) {
  FaultConfig f;
  f.duplicate_ids = {1};
  f.collision = 1.0;
  Bus bus({}, f);
  bus.add(1);
  TimePoint t = TimePoint{} + std::chrono::seconds(1);
  EXPECT_EQ(poll(bus, 1, 20, t).garbled, 20);
}

}  // namespace
}  // namespace lec6::sim
