#include "lec6/lec/memory_map.hpp"

#include <gtest/gtest.h>

#include "lec6/lec/flags.hpp"

namespace lec6::lec {
namespace {

using modbus::ExceptionCode;
using modbus::FunctionCode;

std::optional<ExceptionCode> code(const modbus::Request& r, bool serial = true) {
  auto refusal = check_request(r, serial);
  if (!refusal) return std::nullopt;
  EXPECT_FALSE(refusal->reason.empty());
  return refusal->code;
}

modbus::WriteRegistersRequest regs(uint16_t start, uint16_t n) {
  return modbus::WriteRegistersRequest::of(start, std::vector<uint16_t>(n, 1));
}

modbus::WriteCoilsRequest coils(uint16_t start, uint16_t n) {
  std::unique_ptr<bool[]> bits(new bool[n]());
  return modbus::WriteCoilsRequest::of(start, std::span<const bool>(bits.get(), n));
}

TEST(MemoryMap, ReadsInsideAreasAreAllowedEvenAcrossUndefinedAddresses) {
  EXPECT_FALSE(code(modbus::ReadBitsRequest{FunctionCode::ReadCoils, 0x10, 33}));  // Y10×33 (field)
  EXPECT_FALSE(code(modbus::ReadRegistersRequest{0x9100, 18}));  // D9100×18 (field)
  EXPECT_FALSE(code(modbus::ReadRegistersRequest{0x9000, 7}));
  EXPECT_FALSE(code(modbus::ReadBitsRequest{FunctionCode::ReadInputs, 0x40, 16}));
  EXPECT_FALSE(code(modbus::ReadRegistersRequest{0x0380, 64}));
  EXPECT_FALSE(code(modbus::ReadRegistersRequest{0x000E, 8}));
}

TEST(MemoryMap, EveryExceptionRowOfDigestSection3) {
  // 02: start outside every area.
  EXPECT_EQ(code(modbus::ReadRegistersRequest{0x5000, 1}), ExceptionCode::IllegalAddress);
  EXPECT_EQ(code(modbus::ReadBitsRequest{FunctionCode::ReadInputs, 0x30, 1}),
            ExceptionCode::IllegalAddress);
  // 03: last address beyond the start's area.
  EXPECT_EQ(code(modbus::ReadRegistersRequest{0x9000, 0x101}), ExceptionCode::IllegalAccessRange);
  EXPECT_EQ(code(modbus::ReadBitsRequest{FunctionCode::ReadInputs, 0x40, 17}),
            ExceptionCode::IllegalAccessRange);
  EXPECT_EQ(code(modbus::ReadRegistersRequest{0x0015, 2}), ExceptionCode::IllegalAccessRange);
  // 03: count 0 and counts beyond the limits.
  EXPECT_EQ(code(modbus::ReadRegistersRequest{0x9000, 0}), ExceptionCode::IllegalAccessRange);
  EXPECT_EQ(code(modbus::ReadRegistersRequest{0x0400, 126}), ExceptionCode::IllegalAccessRange);
  EXPECT_EQ(code(modbus::ReadBitsRequest{FunctionCode::ReadCoils, 0, 2001}),
            ExceptionCode::IllegalAccessRange);
  EXPECT_EQ(code(coils(0x00, 257)), ExceptionCode::IllegalAccessRange);
  // 02: writes to read-only or undefined addresses.
  EXPECT_EQ(code(regs(0x9000, 2)), ExceptionCode::IllegalAddress);
  EXPECT_EQ(code(regs(0x000E, 1)), ExceptionCode::IllegalAddress);
  EXPECT_EQ(code(regs(0x0380, 1)), ExceptionCode::IllegalAddress);
  EXPECT_EQ(code(regs(0x9100, 18)), ExceptionCode::IllegalAddress);  // includes D9101
  EXPECT_EQ(code(modbus::WriteCoilRequest{0x31, modbus::kCoilOn}), ExceptionCode::IllegalAddress);
  EXPECT_EQ(code(modbus::WriteCoilRequest{0x05, modbus::kCoilOn}), ExceptionCode::IllegalAddress);
  EXPECT_EQ(code(modbus::WriteCoilRequest{0x20, modbus::kCoilOn}), ExceptionCode::IllegalAddress);
  EXPECT_EQ(code(coils(0x10, 33)), ExceptionCode::IllegalAddress);  // runs over Y20–Y2F
  // 02: echo test code other than 0000.
  EXPECT_EQ(code(modbus::EchoRequest{0x0001, 0x1234}), ExceptionCode::IllegalAddress);
  // 03: FC05 value other than FF00/0000.
  EXPECT_EQ(code(modbus::WriteCoilRequest{0x19, 0x1234}), ExceptionCode::IllegalAccessRange);
  // 03: byte count that disagrees with the count.
  auto mismatch = regs(0x0400, 2);
  mismatch.count = 3;
  EXPECT_EQ(code(mismatch), ExceptionCode::IllegalAccessRange);
}

TEST(MemoryMap, ParallelModeRefusesOperationWrites) {
  const bool parallel = false;
  EXPECT_EQ(code(modbus::WriteCoilRequest{address(Coil::SVON), modbus::kCoilOn}, parallel),
            ExceptionCode::IllegalAddress);
  EXPECT_EQ(code(coils(0x10, 8), parallel), ExceptionCode::IllegalAddress);
  EXPECT_EQ(code(regs(kControlWordY10, 1), parallel), ExceptionCode::IllegalAddress);
  EXPECT_EQ(code(regs(kDirectStart, 1), parallel), ExceptionCode::IllegalAddress);
  // Y30, step data and direct-operation data are writable in either mode.
  EXPECT_FALSE(
      code(modbus::WriteCoilRequest{address(Coil::SerialMode), modbus::kCoilOn}, parallel));
  EXPECT_FALSE(code(regs(0x0400, 16), parallel));
  EXPECT_FALSE(code(regs(kDirectData, 16), parallel));
  EXPECT_FALSE(code(regs(kControlWordY30, 1), parallel));
}

TEST(MemoryMap, CheckOrderGivesOnePredictableCode) {
  // Count 0 at an address outside every area: count (03) is checked first.
  EXPECT_EQ(code(modbus::ReadRegistersRequest{0x5000, 0}), ExceptionCode::IllegalAccessRange);
  // Runs past the area *and* read-only: range (03) before permission (02).
  EXPECT_EQ(code(regs(0x90FF, 2)), ExceptionCode::IllegalAccessRange);
  // Not writable *and* a bad FC05 value: permission (02) before value (03).
  EXPECT_EQ(code(modbus::WriteCoilRequest{0x31, 0x1234}), ExceptionCode::IllegalAddress);
  // Parallel mode *and* a bad value: mode (02) before value (03).
  EXPECT_EQ(code(modbus::WriteCoilRequest{0x19, 0x1234}, false), ExceptionCode::IllegalAddress);
}

TEST(MemoryMap, AddressNamesUseTheManualsTerms) {
  EXPECT_EQ(address_name(Space::Coil, 0x19), "Y19 SVON");
  EXPECT_EQ(address_name(Space::Input, 0x49), "X49 SVRE");
  EXPECT_EQ(address_name(Space::Register, 0x9000), "D9000 current position");
  EXPECT_EQ(address_name(Space::Register, 0x0412), "D0412 step 1 position (high word)");
  EXPECT_EQ(address_name(Space::Register, 0x9108), "D9108 direct operation push");
  EXPECT_NE(explain_exception(ExceptionCode::IllegalAddress).find("lec serial on"),
            std::string::npos);
}

}  // namespace
}  // namespace lec6::lec
