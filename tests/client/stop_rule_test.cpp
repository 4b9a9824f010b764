// The one rule for what is a stop (client::stops_or_releases): every coil at
// both levels, single and multiple coil writes, and what is never a stop.
// lec serve's priorities (serve::priority_of) and Ctrl-C on the client's own
// line both use it; tests/serve/line/scheduler_test.cpp checks the former.

#include <gtest/gtest.h>

#include <vector>

#include "lec6/client/interrupt.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/lec/memory_map.hpp"

namespace lec6::client {
namespace {

using lec::Coil;

modbus::Request coil(uint16_t address, bool on) {
  return modbus::WriteCoilRequest{address, on ? modbus::kCoilOn : modbus::kCoilOff};
}

modbus::Request coils(uint16_t start, std::vector<bool> levels) {
  bool bits[32] = {};
  for (std::size_t i = 0; i < levels.size(); ++i) bits[i] = levels[i];
  return modbus::WriteCoilsRequest::of(start, std::span<const bool>(bits, levels.size()));
}

struct RuleRow {
  uint16_t address;
  const char* name;
  bool stops_when_on;
  bool stops_when_off;
};

// Every coil of the map (Y10–Y1E, Y30) and every address between: at 1, at 0.
TEST(StopRule, EveryCoilAtBothLevels) {
  const std::vector<RuleRow> table = {
      {0x10, "IN0", false, false},
      {0x11, "IN1", false, false},
      {0x12, "IN2", false, false},
      {0x13, "IN3", false, false},
      {0x14, "IN4", false, false},
      {0x15, "IN5", false, false},
      {0x16, "(unused)", false, false},
      {0x17, "(unused)", false, false},
      {0x18, "HOLD", true, false},  // HOLD off resumes a held operation
      {0x19, "SVON", false, true},
      {0x1A, "DRIVE", false, true},
      {0x1B, "RESET", true, true},  // both halves of the pulse
      {0x1C, "SETUP", false, true},
      {0x1D, "JOG-", false, true},
      {0x1E, "JOG+", false, true},
      {0x1F, "(unused)", false, false},
      {0x30, "Y30 serial mode", false, false},
  };
  for (const RuleRow& r : table) {
    EXPECT_EQ(stops_or_releases(coil(r.address, true)), r.stops_when_on) << r.name << " <- 1";
    EXPECT_EQ(stops_or_releases(coil(r.address, false)), r.stops_when_off) << r.name << " <- 0";
    // The same level written by FC0F over that one coil reads the same.
    EXPECT_EQ(stops_or_releases(coils(r.address, {true})), r.stops_when_on) << r.name << " FC0F 1";
    EXPECT_EQ(stops_or_releases(coils(r.address, {false})), r.stops_when_off)
        << r.name << " FC0F 0";
  }
}

TEST(StopRule, ACoilValueTheControllerRefusesIsNoStop) {
  EXPECT_FALSE(stops_or_releases(modbus::WriteCoilRequest{lec::address(Coil::RESET), 0x1234}));
}

TEST(StopRule, ABlockWriteStopsWhenAnyLevelStops) {
  // Y18–Y1F as a PLC writes them each scan: HOLD, SVON, DRIVE, RESET, SETUP, JOG-, JOG+.
  EXPECT_TRUE(stops_or_releases(coils(0x18, {false, true, false, true, false, false, false})))
      << "RESET <- 1 with the servo on and HOLD off is a stop";
  EXPECT_TRUE(stops_or_releases(coils(0x18, {true, true, false, false, false, false, false})))
      << "HOLD <- 1";
  EXPECT_TRUE(stops_or_releases(coils(0x18, {false, false, false, false, false, false, false})))
      << "SVON <- 0";
  EXPECT_FALSE(stops_or_releases(coils(0x18, {false, true, true, false, false, false, false})))
      << "DRIVE <- 1 starts a step";
  EXPECT_FALSE(stops_or_releases(coils(0x18, {false, true, false, false, false, false, false})))
      << "HOLD <- 0 and SVON <- 1 with nothing else: levels that may start";
  EXPECT_TRUE(stops_or_releases(coils(0x1A, {false, false})))
      << "DRIVE <- 0 and RESET <- 0: releases only";
  EXPECT_FALSE(stops_or_releases(coils(0x10, {true, false, true, false, false, false})))
      << "a step number";
}

TEST(StopRule, ReadsAndRegisterWritesAreNoStops) {
  EXPECT_FALSE(stops_or_releases(modbus::ReadRegistersRequest{0x9000, 7}));
  EXPECT_FALSE(stops_or_releases(
      modbus::ReadBitsRequest{modbus::FunctionCode::ReadCoils, lec::address(Coil::RESET), 1}));
  EXPECT_FALSE(stops_or_releases(modbus::WriteRegistersRequest{0x9100, 1, {0x01, 0x00}}));
  EXPECT_FALSE(stops_or_releases(modbus::EchoRequest{0}));
}

modbus::Request words(uint16_t start, std::vector<uint16_t> values) {
  return modbus::WriteRegistersRequest::of(start, values);
}

// Issue 31 rule 3: the control words are the coils written at once. Every
// value of D90C1 (Y10-Y1F, bit 0 = Y10) stops exactly when the same levels
// written by FC0F over Y10-Y1F would; D90C2 (Y30-Y3F) never stops.
TEST(StopRule, EveryValueOfTheControlWordsReadsAsItsCoils) {
  for (uint32_t v = 0; v <= 0xFFFF; ++v) {
    std::vector<bool> bits(16);
    for (int b = 0; b < 16; ++b) bits[b] = ((v >> b) & 1U) != 0;
    const bool as_coils = stops_or_releases(coils(0x10, bits));
    ASSERT_EQ(stops_or_releases(words(lec::kControlWordY10, {static_cast<uint16_t>(v)})), as_coils)
        << "D90C1 = " << v;
    // Both words in one FC10: Y30 neither stops nor starts.
    ASSERT_EQ(stops_or_releases(words(lec::kControlWordY10, {static_cast<uint16_t>(v), 1})),
              as_coils)
        << "D90C1-D90C2 = " << v << ", 1";
    ASSERT_FALSE(stops_or_releases(words(lec::kControlWordY30, {static_cast<uint16_t>(v)})))
        << "D90C2 = " << v;
  }
}

TEST(StopRule, APlcsControlWordImages) {
  const auto bit = [](Coil c) { return static_cast<uint16_t>(1U << (lec::address(c) - 0x10)); };
  const uint16_t svon = bit(Coil::SVON);
  EXPECT_TRUE(stops_or_releases(words(lec::kControlWordY10, {uint16_t(svon | bit(Coil::HOLD))})))
      << "HOLD as a word";
  EXPECT_TRUE(stops_or_releases(words(lec::kControlWordY10, {uint16_t(svon | bit(Coil::RESET))})))
      << "RESET as a word";
  EXPECT_TRUE(stops_or_releases(words(lec::kControlWordY10, {0}))) << "servo off as a word";
  EXPECT_FALSE(stops_or_releases(words(lec::kControlWordY10, {uint16_t(svon | bit(Coil::DRIVE))})))
      << "a start as a word";
  EXPECT_FALSE(stops_or_releases(words(lec::kControlWordY10, {svon}))) << "servo on, nothing else";
  // A block that begins before the control word still writes it.
  EXPECT_TRUE(stops_or_releases(words(0x90C0, {0, uint16_t(svon | bit(Coil::HOLD))})));
  EXPECT_FALSE(stops_or_releases(words(0x90C3, {0}))) << "past the control words";
}

// The two halves lec serve's supersede rule needs (scheduler.cpp): a hard
// stop (RESET, HOLD <- 1, SVON <- 0) and a write that may start motion. Every
// coil at both levels, in each encoding (FC05, FC0F, the control word).
TEST(StopRule, HardStopsAndStartsForEveryCoilInEveryEncoding) {
  struct Row {
    uint16_t address;
    bool hard_on, hard_off, starts_on, starts_off;
  };
  const std::vector<Row> table = {
      {0x10, false, false, false, false},  // IN0
      {0x15, false, false, false, false},  // IN5
      {0x18, true, false, false, true},    // HOLD: 0 resumes
      {0x19, false, true, true, false},    // SVON
      {0x1A, false, false, true, false},   // DRIVE
      {0x1B, true, false, false, false},   // RESET
      {0x1C, false, false, true, false},   // SETUP
      {0x1D, false, false, true, false},   // JOG-
      {0x1E, false, false, true, false},   // JOG+
      {0x30, false, false, false, false},  // serial mode
  };
  for (const Row& r : table) {
    for (bool on : {true, false}) {
      const bool hard = on ? r.hard_on : r.hard_off;
      const bool starts = on ? r.starts_on : r.starts_off;
      std::vector<modbus::Request> encodings = {coil(r.address, on), coils(r.address, {on})};
      if (r.address < 0x20) {
        const uint16_t word[] = {static_cast<uint16_t>(on ? 1U << (r.address - 0x10) : 0U)};
        // A word writes all 16 coils: only the 1 written is judged alone when
        // the others are 0 (HOLD <- 0 among them starts, SVON <- 0 stops).
        if (on) encodings.push_back(modbus::WriteRegistersRequest::of(lec::kControlWordY10, word));
      }
      for (const auto& e : encodings) {
        if (std::holds_alternative<modbus::WriteRegistersRequest>(e)) {
          // The word also writes HOLD <- 0 (starts, unless this is HOLD)
          // and SVON <- 0 (a hard stop, unless this is SVON).
          EXPECT_EQ(stops_hard(e), hard || r.address != 0x19) << std::hex << r.address;
          EXPECT_EQ(starts_motion(e), starts || r.address != 0x18) << std::hex << r.address;
        } else {
          EXPECT_EQ(stops_hard(e), hard) << std::hex << r.address << " <- " << on;
          EXPECT_EQ(starts_motion(e), starts) << std::hex << r.address << " <- " << on;
        }
      }
    }
  }
  const uint16_t start[] = {lec::kDirectStartValue};
  EXPECT_TRUE(starts_motion(modbus::WriteRegistersRequest::of(lec::kDirectStart, start)));
  EXPECT_FALSE(stops_hard(modbus::WriteRegistersRequest::of(lec::kDirectStart, start)));
  const uint16_t data[] = {1, 2};
  EXPECT_FALSE(starts_motion(modbus::WriteRegistersRequest::of(lec::kDirectData, data)));
  EXPECT_FALSE(starts_motion(modbus::ReadRegistersRequest{lec::kDirectStart, 1}));
}

}  // namespace
}  // namespace lec6::client
