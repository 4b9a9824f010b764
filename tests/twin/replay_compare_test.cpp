// The fidelity report on in-memory exchanges (sans-I/O): pairing, discrete
// and motion values, silence, response times.

#include <gtest/gtest.h>

#include "lec6/twin/replay.hpp"

namespace lec6::twin {
namespace {

modbus::Bytes frame(std::string_view hex) {
  auto b = modbus::from_hex(hex).value();
  modbus::append_crc(b);
  return b;
}

Exchange ex(std::string_view q, std::optional<std::string_view> r, int64_t at_us, int64_t rt_us) {
  Exchange e;
  e.query = frame(q);
  e.query_start_us = at_us;
  e.query_end_us = at_us + 2000;
  if (r) {
    e.reply = frame(*r);
    e.reply_end_us = e.query_end_us + rt_us;
    e.reply_start_us = e.reply_end_us - 2000;
  }
  return e;
}

TEST(ReplayCompare, PairsQueriesWithTheirReplies) {
  std::vector<LineRecord> recs{
      {LineRecord::Kind::Query, 0, 2000, frame("01 03 9000 0002"), 2},
      {LineRecord::Kind::Noise, 2500, 2600, {0xFF}, 3},
      {LineRecord::Kind::Reply, 9000, 11000, frame("01 03 04 0000 3A98"), 4},
      {LineRecord::Kind::Query, 20000, 22000, frame("01 02 0040 0010"), 5},
      {LineRecord::Kind::Query, 90000, 92000, frame("01 02 0040 0010"), 6},
      {LineRecord::Kind::Unknown, 99000, 100000, frame("01 02 02 00 0E"), 7},
  };
  const auto e = pair_exchanges(recs);
  ASSERT_EQ(e.size(), 3u);
  EXPECT_EQ(e[0].line, 2u);
  ASSERT_TRUE(e[0].reply);
  EXPECT_EQ(*e[0].response_us(), 9000);
  EXPECT_FALSE(e[1].reply);  // silence
  ASSERT_TRUE(e[2].reply);   // an unknown record with a sound CRC after a query
}

TEST(ReplayCompare, NamesEachValueInTheManualsTerms) {
  // Captured: position 150.00 → 149.98 mm; flags SVRE+SETON+INP; a write echo.
  const std::vector<Exchange> captured{
      ex("01 03 9000 0004", "01 03 08 0000 3A96 0064 000A", 0, 9000),
      ex("01 02 0040 0010", "01 02 02 00 0E", 20000, 9000),
      ex("01 05 0019 FF00", "01 05 0019 FF00", 40000, 9000)};
  const std::vector<Exchange> twin{ex("01 03 9000 0004", "01 03 08 0000 3A98 0064 000A", 0, 8000),
                                   ex("01 02 0040 0010", "01 02 02 00 0F", 20000, 8000),
                                   ex("01 05 0019 FF00", "01 05 0019 FF00", 40000, 8000)};
  const auto r = compare(captured, twin);
  EXPECT_EQ(r.identical, 1u);
  EXPECT_EQ(r.within_tolerance, 1u);  // 0.02 mm ≤ 0.05 mm
  EXPECT_EQ(r.differing, 1u);         // BUSY differs
  ASSERT_EQ(r.differences.size(), 2u);
  EXPECT_EQ(r.differences[0].text(),
            "line 0, 0.000 s: D9000 position: captured 149.98 mm, twin 150.00 mm (within "
            "tolerance)");
  EXPECT_EQ(r.differences[1].what, "X48 BUSY");
  EXPECT_EQ(r.differences[1].captured, "0");
  EXPECT_NEAR(r.max_position_delta_mm, 0.02, 1e-9);
  // Response times: 9 ms captured, 8 ms replayed: −11 %, beyond ±10 %.
  EXPECT_FALSE(r.response_time_matches);
  EXPECT_NEAR(r.response_paired_change, -1.0 / 9.0, 1e-9);
  EXPECT_NE(r.text().find("response time: captured p50 9.0 ms (p95 9.0), twin p50 8.0 ms (p95 "
                          "8.0); exchange by exchange -11.1 % (median, beyond ±10 %)"),
            std::string::npos)
      << r.text();
}

TEST(ReplayCompare, SilenceAndExceptionsAreDifferences) {
  const std::vector<Exchange> captured{ex("01 03 9000 0002", "01 03 04 0000 0000", 0, 9000),
                                       ex("01 03 0000 0001", "01 83 02", 20000, 9000)};
  const std::vector<Exchange> twin{ex("01 03 9000 0002", std::nullopt, 0, 0),
                                   ex("01 03 0000 0001", "01 03 02 0000", 20000, 9000)};
  const auto r = compare(captured, twin);
  EXPECT_EQ(r.differing, 2u);
  EXPECT_EQ(r.differences[0].replayed, "no reply");
  EXPECT_EQ(r.differences[1].what, "reply bytes");
  EXPECT_FALSE(r.matches());
}

TEST(ReplayCompare, AFlagEdgeOnePollApartMatchesOnlyWithinTheEdgeTolerance) {
  // The captured controller still says BUSY at 60 ms; the twin's BUSY fell
  // between the polls at 30 and 60 ms, and it said BUSY at 30 ms.
  const std::vector<Exchange> captured{ex("01 02 0040 0010", "01 02 02 00 01", 0, 9000),
                                       ex("01 02 0040 0010", "01 02 02 00 01", 30000, 9000),
                                       ex("01 02 0040 0010", "01 02 02 00 01", 60000, 9000),
                                       ex("01 02 0040 0010", "01 02 02 00 08", 90000, 9000)};
  const std::vector<Exchange> twin{ex("01 02 0040 0010", "01 02 02 00 01", 0, 9000),
                                   ex("01 02 0040 0010", "01 02 02 00 01", 30000, 9000),
                                   ex("01 02 0040 0010", "01 02 02 00 08", 60000, 9000),
                                   ex("01 02 0040 0010", "01 02 02 00 08", 90000, 9000)};
  // Strict by default: BUSY and INP at 60 ms differ.
  const auto strict = compare(captured, twin);
  EXPECT_EQ(strict.differing, 1u);
  EXPECT_FALSE(strict.matches());
  // 20 ms reaches no neighbour (30 ms away): still differs.
  ReplayTolerance near;
  near.edge_ms = 20;
  EXPECT_EQ(compare(captured, twin, near).differing, 1u);
  // 30 ms: the twin shows BUSY=1 and INP=0 at 30 ms, one poll before.
  ReplayTolerance poll;
  poll.edge_ms = 30;
  const auto r = compare(captured, twin, poll);
  EXPECT_EQ(r.differing, 0u);
  EXPECT_EQ(r.within_tolerance, 1u);
  ASSERT_EQ(r.differences.size(), 2u);
  EXPECT_TRUE(r.differences[0].edge);
  EXPECT_TRUE(r.differences[0].within_tolerance);
  EXPECT_NE(r.differences[0].text().find("an edge within tolerance"), std::string::npos);
  EXPECT_NE(r.text().find("flag edges ±30 ms"), std::string::npos) << r.text();
  EXPECT_NE(r.json().find("\"edge_ms\": 30"), std::string::npos);
  // A flag the twin never shows that way is not an edge, however wide the tolerance.
  auto never = captured;
  never[2] = ex("01 02 0040 0010", "01 02 02 00 81", 60000, 9000);  // BUSY, ALARM = 1
  ReplayTolerance wide;
  wide.edge_ms = 1000;
  const auto a = compare(never, twin, wide);
  EXPECT_EQ(a.differing, 1u);
  bool alarm_beyond = false;
  for (const auto& d : a.differences)
    if (d.what == "X4F ALARM") alarm_beyond = !d.within_tolerance && !d.edge;
  EXPECT_TRUE(alarm_beyond) << a.text();
}

}  // namespace
}  // namespace lec6::twin
