#include "lec6/lec/memory_map.hpp"

#include <fmt/format.h>

#include <array>

#include "lec6/lec/flags.hpp"
#include "lec6/lec/step_data.hpp"

namespace lec6::lec {
namespace {

using modbus::ExceptionCode;

constexpr std::array<Area, 7> kAreas{{
    {Space::Coil, 0x00, 0x3F, "Y coils"},
    {Space::Input, 0x40, 0x4F, "X inputs"},
    {Space::Register, 0x000E, 0x0015, "equipment name"},
    {Space::Register, 0x0380, 0x03BF, "alarm history"},
    {Space::Register, 0x0400, 0x07FF, "step data"},
    {Space::Register, 0x9000, 0x90FF, "state data"},
    {Space::Register, 0x9100, 0x9111, "direct operation"},
}};

std::string_view space_letter(Space s) {
  switch (s) {
    case Space::Coil:
      return "Y";
    case Space::Input:
      return "X";
    case Space::Register:
      return "D";
  }
  return "?";
}

std::string addr(Space s, uint16_t a) {
  return s == Space::Register ? fmt::format("D{:04X}", a)
                              : fmt::format("{}{:02X}", space_letter(s), a);
}

Refusal refuse(ExceptionCode code, std::string reason) {
  return Refusal{code, std::move(reason)};
}

struct Access {
  Space space;
  uint16_t start;
  uint16_t count;
  bool write;
};

std::optional<Refusal> check_range(const Access& a) {
  const Area* area = find_area(a.space, a.start);
  if (!area) {
    return refuse(ExceptionCode::IllegalAddress,
                  fmt::format("start address {} is outside every area of the memory map",
                              addr(a.space, a.start)));
  }
  const uint32_t last = static_cast<uint32_t>(a.start) + a.count - 1;
  if (last > area->last) {
    return refuse(ExceptionCode::IllegalAccessRange,
                  fmt::format("{} points from {} run past the end of the {} area ({})", a.count,
                              addr(a.space, a.start), area->name, addr(a.space, area->last)));
  }
  return std::nullopt;
}

std::optional<Refusal> check_write(const Access& a, bool serial_mode) {
  for (uint32_t x = a.start; x < static_cast<uint32_t>(a.start) + a.count; ++x) {
    const auto address = static_cast<uint16_t>(x);
    switch (write_rule(a.space, address)) {
      case WriteRule::Always:
        break;
      case WriteRule::SerialModeOnly:
        if (!serial_mode) {
          return refuse(ExceptionCode::IllegalAddress,
                        fmt::format("{} cannot be written in parallel input mode (Y30 = 0)",
                                    addr(a.space, address)));
        }
        break;
      case WriteRule::Refused:
        return refuse(ExceptionCode::IllegalAddress,
                      fmt::format("{} is not writable", addr(a.space, address)));
    }
  }
  return std::nullopt;
}

std::optional<Refusal> check_access(const Access& a, bool serial_mode) {
  if (auto r = check_range(a)) return r;
  if (a.write) return check_write(a, serial_mode);
  return std::nullopt;
}

}  // namespace

std::span<const Area> areas() noexcept {
  return kAreas;
}

const Area* find_area(Space space, uint16_t address) noexcept {
  for (const Area& a : kAreas) {
    if (a.space == space && address >= a.first && address <= a.last) return &a;
  }
  return nullptr;
}

WriteRule write_rule(Space space, uint16_t address) noexcept {
  switch (space) {
    case Space::Input:
      return WriteRule::Refused;
    case Space::Coil:
      if (address == static_cast<uint16_t>(Coil::SerialMode)) return WriteRule::Always;
      if (address >= 0x10 && address <= 0x1F) return WriteRule::SerialModeOnly;
      return WriteRule::Refused;
    case Space::Register:
      if (address >= kStepData && address <= 0x07FF) return WriteRule::Always;
      if (address >= kDirectData && address <= 0x9111) return WriteRule::Always;
      if (address == kControlWordY30) return WriteRule::Always;
      if (address == kControlWordY10 || address == kDirectStart) return WriteRule::SerialModeOnly;
      return WriteRule::Refused;
  }
  return WriteRule::Refused;
}

std::optional<Refusal> check_request(const modbus::Request& request, bool serial_mode) {
  using namespace modbus;
  // Counts and byte counts first (03): the codec's limits, one definition.
  if (auto e = check_counts(request)) return refuse(ExceptionCode::IllegalAccessRange, e->message);
  struct Visitor {
    bool serial_mode;
    std::optional<Refusal> operator()(const ReadBitsRequest& q) const {
      const Space s = q.function == FunctionCode::ReadCoils ? Space::Coil : Space::Input;
      return check_access({s, q.start, q.count, false}, serial_mode);
    }
    std::optional<Refusal> operator()(const ReadRegistersRequest& q) const {
      return check_access({Space::Register, q.start, q.count, false}, serial_mode);
    }
    std::optional<Refusal> operator()(const WriteCoilRequest& q) const {
      if (auto r = check_access({Space::Coil, q.coil, 1, true}, serial_mode)) return r;
      if (q.value != kCoilOn && q.value != kCoilOff) {
        return refuse(
            ExceptionCode::IllegalAccessRange,
            fmt::format("coil value {:04X}h is neither FF00h (ON) nor 0000h (OFF)", q.value));
      }
      return std::nullopt;
    }
    std::optional<Refusal> operator()(const EchoRequest& q) const {
      if (q.test_code != 0) {
        return refuse(
            ExceptionCode::IllegalAddress,
            fmt::format("echo test code {:04X}h: the controller only knows 0000h", q.test_code));
      }
      return std::nullopt;
    }
    std::optional<Refusal> operator()(const WriteCoilsRequest& q) const {
      return check_access({Space::Coil, q.start, q.count, true}, serial_mode);
    }
    std::optional<Refusal> operator()(const WriteRegistersRequest& q) const {
      return check_access({Space::Register, q.start, q.count, true}, serial_mode);
    }
  };
  return std::visit(Visitor{serial_mode}, request);
}

std::string explain_exception(modbus::ExceptionCode code) {
  switch (code) {
    case modbus::ExceptionCode::IllegalFunction:
      return "01: illegal function — the controller does not have this function code (it has 01, "
             "02, "
             "03, 05, 08, 0F, 10; a single register is written with 10, not 06)";
    case modbus::ExceptionCode::IllegalAddress:
      return "02: address refused — the address is outside the memory map or read-only, or the "
             "write "
             "is refused in parallel input mode (run `lec serial on` to set Y30)";
    case modbus::ExceptionCode::IllegalAccessRange:
      return "03: access range refused — the count is 0 or too large, the access runs past the end "
             "of "
             "its area, or a coil value is not FF00h/0000h";
    case modbus::ExceptionCode::ServerDeviceFailure:
      return "04: not carried out by the gateway: lec serve refuses a write that would start or "
             "resume motion when a stop to its controller came after it; otherwise the gateway "
             "failed while handling the request (see the lec serve log)";
    case modbus::ExceptionCode::ServerBusy:
      return "06: the gateway is busy (shutting down): try again later";
    case modbus::ExceptionCode::GatewayPathUnavailable:
      return "0A: gateway path unavailable — this unit ID is not configured on the gateway's lines";
    case modbus::ExceptionCode::GatewayTargetFailed:
      return "0B: the gateway's target device did not answer (timeout, or backed off after "
             "repeated timeouts)";
  }
  return "unknown exception code";
}

std::string address_name(Space space, uint16_t address) {
  if (space == Space::Input && address >= 0x40 && address <= 0x4F) {
    return fmt::format("X{:02X} {}", address,
                       status_flag_name(static_cast<unsigned>(address - 0x40)));
  }
  if (space == Space::Coil) {
    const std::string_view n = coil_name(address);
    return n.empty() ? fmt::format("Y{:02X}", address) : fmt::format("Y{:02X} {}", address, n);
  }
  if (space != Space::Register) return {};
  const std::string d = fmt::format("D{:04X}", address);
  if (address >= kEquipmentName && address <= 0x0015) return d + " equipment name";
  if (address >= kAlarmHistory && address <= 0x03BF) {
    return fmt::format("{} alarm history group {}", d, (address - kAlarmHistory) / 4);
  }
  if (address >= kStepData && address <= 0x07FF) {
    const unsigned step = (address - kStepData) / kStepStride;
    return fmt::format("{} step {} {}", d, step,
                       step_register_name((address - kStepData) % kStepStride));
  }
  if (address >= kDirectData && address <= 0x9111) {
    return fmt::format("{} direct operation {}", d, step_register_name(address - kDirectData));
  }
  switch (address) {
    case 0x9000:
    case 0x9001:
      return d + " current position";
    case 0x9002:
      return d + " current speed";
    case 0x9003:
      return d + " current thrust";
    case 0x9004:
    case 0x9005:
      return d + " target position";
    case 0x9006:
      return d + " driving step No.";
    case kStatusWord:
      return d + " X40–X4F flags";
    case kControlWordY10:
      return d + " Y10–Y1F flags";
    case kControlWordY30:
      return d + " Y30–Y3F flags";
    case kDirectStart:
      return d + " direct operation start";
    default:
      return d;
  }
}

}  // namespace lec6::lec
