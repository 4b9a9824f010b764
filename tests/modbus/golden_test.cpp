// Every frame of the manual (tests/data/manual-frames.tsv) is produced byte for
// byte by encoding its meaning, and decoding it gives that meaning back.

#include <gtest/gtest.h>

#include <map>

#include "golden_frames.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/lec/state_data.hpp"
#include "lec6/lec/step_data.hpp"
#include "lec6/modbus/pdu.hpp"

namespace lec6::modbus {
namespace {

using lec::Coil;

RequestFrame coil(uint8_t id, Coil c, bool on) {
  return {id, WriteCoilRequest{lec::address(c), on ? kCoilOn : kCoilOff}};
}

RequestFrame direct_operation_300mm() {
  lec::StepData d;
  d.movement_mode = lec::MovementMode::Absolute;
  d.speed_mm_s = 500;
  d.position_001mm = 30000;
  d.acceleration_mm_s2 = 5000;
  d.deceleration_mm_s2 = 5000;
  d.pushing_speed_mm_s = 20;
  d.moving_force_pct = 100;
  d.in_position_001mm = 100;
  const auto regs = d.to_registers();
  return {1, WriteRegistersRequest::of(lec::kDirectData, regs)};
}

RequestFrame step1_position_150mm() {
  const uint16_t regs[] = {0x0000, 15000};
  return {1, WriteRegistersRequest::of(lec::step_address(1) + 2, regs)};
}

RequestFrame select_step_2() {
  const bool bits[] = {false, true, false, false, false, false, false, false};  // IN1
  return {1, WriteCoilsRequest::of(lec::address(Coil::IN0), bits)};
}

ResponseFrame inputs(lec::StatusFlags f) {
  const auto p = f.packed();
  return {1, ReadBitsResponse{FunctionCode::ReadInputs, Bytes(p.begin(), p.end())}};
}

lec::StatusFlags flags(std::initializer_list<lec::StatusFlags::Bit> on) {
  lec::StatusFlags f;
  for (auto b : on) f.set(b, true);
  return f;
}

// The meaning of each golden frame, typed. Keyed by its hex so that the file
// stays the source of which frames exist.
const std::map<std::string, RequestFrame>& queries() {
  static const std::map<std::string, RequestFrame> m{
      {"01 05 00 30 FF 00 8C 35", coil(1, Coil::SerialMode, true)},
      {"01 05 00 19 FF 00 5D FD", coil(1, Coil::SVON, true)},
      {"01 02 00 40 00 10 78 12", {1, ReadBitsRequest{FunctionCode::ReadInputs, 0x40, 16}}},
      {"01 05 00 1C FF 00 4D FC", coil(1, Coil::SETUP, true)},
      {"01 05 00 1C 00 00 0C 0C", coil(1, Coil::SETUP, false)},
      {"01 0F 00 10 00 08 01 02 BE 97", select_step_2()},
      {"01 05 00 1A FF 00 AD FD", coil(1, Coil::DRIVE, true)},
      {"01 05 00 1A 00 00 EC 0D", coil(1, Coil::DRIVE, false)},
      {"01 10 04 12 00 02 04 00 00 3A 98 52 B0", step1_position_150mm()},
      {"01 03 90 00 00 02 E9 0B", {1, ReadRegistersRequest{lec::kStateData, 2}}},
      {"01 10 91 02 00 10 20 00 01 01 F4 00 00 75 30 13 88 13 88 00 00 00 00 00 14 00 64 00 00 00 "
       "00 "
       "00 00 00 00 00 00 00 64 72 48",
       direct_operation_300mm()},
      {"01 10 91 00 00 01 02 01 00 27 09",
       {1, WriteRegistersRequest::of(lec::kDirectStart,
                                     std::vector<uint16_t>{lec::kDirectStartValue})}},
      {"20 08 00 00 5A A5 1C 61", {0x20, EchoRequest{0x0000, 0x5AA5}}},
  };
  return m;
}

const std::map<std::string, ResponseFrame>& responses() {
  using B = lec::StatusFlags;
  static const std::map<std::string, ResponseFrame> m{
      {"01 02 02 00 02 38 79", inputs(flags({B::Svre}))},
      {"01 02 02 00 0E 38 7C", inputs(flags({B::Svre, B::Seton, B::Inp}))},
      {"01 03 04 00 00 3A 98 E9 39", {1, ReadRegistersResponse{{0x0000, 0x3A98}}}},
  };
  return m;
}

TEST(GoldenFrames, EveryRowOfTheFileIsCovered) {
  const auto frames = testing::load_golden_frames();
  ASSERT_FALSE(frames.empty());
  for (const auto& g : frames) {
    const std::string hex = to_hex(g.bytes);
    if (g.query) {
      EXPECT_TRUE(queries().count(hex))
          << "no typed meaning for query " << g.section << ": " << hex;
    } else {
      EXPECT_TRUE(responses().count(hex))
          << "no typed meaning for response " << g.section << ": " << hex;
    }
  }
}

TEST(GoldenFrames, EncodingTheMeaningGivesTheBytes) {
  for (const auto& g : testing::load_golden_frames()) {
    const std::string hex = to_hex(g.bytes);
    if (g.query) {
      auto encoded = encode_request(queries().at(hex));
      ASSERT_TRUE(encoded) << encoded.error().message;
      EXPECT_EQ(to_hex(*encoded), hex) << g.section << " " << g.meaning;
    } else {
      EXPECT_EQ(to_hex(encode_response(responses().at(hex))), hex) << g.section << " " << g.meaning;
    }
  }
}

TEST(GoldenFrames, DecodingTheBytesGivesTheMeaning) {
  for (const auto& g : testing::load_golden_frames()) {
    const std::string hex = to_hex(g.bytes);
    if (g.query) {
      auto decoded = decode_request(g.bytes);
      ASSERT_TRUE(decoded) << g.section << ": " << decoded.error().message;
      EXPECT_EQ(*decoded, queries().at(hex)) << g.section << " " << g.meaning;
    } else {
      auto decoded = decode_response(g.bytes);
      ASSERT_TRUE(decoded) << g.section << ": " << decoded.error().message;
      EXPECT_EQ(*decoded, responses().at(hex)) << g.section << " " << g.meaning;
    }
  }
}

TEST(GoldenFrames, TypedValuesReadBackFromTheManualReplies) {
  auto pos = decode_response(*from_hex("01 03 04 00 00 3A 98 E9 39"));
  ASSERT_TRUE(pos);
  const auto& regs = std::get<ReadRegistersResponse>(pos->pdu).values;
  // D9000×2 is the position half of the state record.
  std::vector<uint16_t> state(regs.begin(), regs.end());
  state.resize(lec::StateData::kRegisters);
  EXPECT_EQ(lec::StateData::from_registers(state).position_001mm, 15000);

  auto homed = decode_response(*from_hex("01 02 02 00 0E 38 7C"));
  ASSERT_TRUE(homed);
  const auto f = lec::StatusFlags::from_packed(std::get<ReadBitsResponse>(homed->pdu).packed);
  EXPECT_TRUE(f.svre());
  EXPECT_TRUE(f.seton());
  EXPECT_TRUE(f.inp());
  EXPECT_FALSE(f.busy());
  EXPECT_EQ(f.describe(), "SVRE SETON INP");
}

}  // namespace
}  // namespace lec6::modbus
