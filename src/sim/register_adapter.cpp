// The twin controller's serial interface: the LEC memory map (digest §4)
// onto the controller's inputs and outputs. A request is checked against the
// controller's access rules (lec::check_request), decoded into reads of its
// flags, state and EEPROM and writes of its control flags, direct-operation
// data and step data, and answered. The state machine behind those inputs is
// controller.cpp and controller_operations.cpp; this file knows addresses,
// the state machine does not.

#include <map>
#include <optional>
#include <span>
#include <type_traits>
#include <variant>
#include <vector>

#include "lec6/lec/memory_map.hpp"
#include "lec6/sim/controller.hpp"

namespace lec6::sim {

namespace {

using lec::Coil;
using modbus::FunctionCode;

constexpr bool in_range(uint32_t a, uint32_t first, uint32_t count) {
  return a >= first && a < first + count;
}

constexpr uint16_t with_bit(uint16_t word, unsigned bit, bool on) {
  return on ? static_cast<uint16_t>(word | (1u << bit))
            : static_cast<uint16_t>(word & ~(1u << bit));
}

modbus::Response read_bits(Controller& c, const modbus::ReadBitsRequest& q) {
  modbus::ReadBitsResponse r;
  r.function = q.function;
  r.packed.assign((q.count + 7u) / 8u, 0);
  const uint16_t x = c.status(c.now()).bits;
  const lec::ControlFlags y = c.control();
  for (uint16_t i = 0; i < q.count; ++i) {
    const uint32_t a = static_cast<uint32_t>(q.start) + i;
    bool on = false;
    if (q.function == FunctionCode::ReadCoils) {
      if (a >= 0x10 && a <= 0x1F) on = (y.y10_1f >> (a - 0x10)) & 1u;
      if (a == lec::address(Coil::SerialMode)) on = y.serial_mode;
    } else if (in_range(a, lec::kStatusInputs, lec::kStatusInputCount)) {
      on = (x >> (a - lec::kStatusInputs)) & 1u;
    }
    if (on) r.packed[i / 8] = static_cast<uint8_t>(r.packed[i / 8] | (1u << (i % 8)));
  }
  return r;
}

uint16_t read_register(Controller& c, uint16_t a) {
  const Eeprom& e = c.eeprom();
  if (in_range(a, lec::kEquipmentName, lec::kEquipmentNameRegisters)) {
    return e.name.to_registers()[a - lec::kEquipmentName];
  }
  if (in_range(a, lec::kAlarmHistory, lec::kAlarmHistoryRegisters)) {
    return e.alarms.to_registers()[a - lec::kAlarmHistory];
  }
  if (in_range(a, lec::kStepData, lec::kStepCount * lec::kStepStride)) {
    const unsigned off = a - lec::kStepData;
    return e.steps[off / lec::kStepStride].to_registers()[off % lec::kStepStride];
  }
  if (in_range(a, lec::kStateData, lec::kStateDataRegisters)) {
    return c.state(c.now()).to_registers()[a - lec::kStateData];
  }
  if (a == lec::kStatusWord) return c.status(c.now()).bits;
  if (a == lec::kControlWordY10) return c.control().y10_1f;
  if (a == lec::kControlWordY30) return c.control().serial_mode ? 1 : 0;
  if (in_range(a, lec::kDirectData, Controller::kDirectDataRegisters)) {
    return c.direct_data()[a - lec::kDirectData];
  }
  return 0;  // undefined inside an area, and D9100 once the start is processed
}

modbus::Response read_registers(Controller& c, const modbus::ReadRegistersRequest& q) {
  modbus::ReadRegistersResponse r;
  r.values.reserve(q.count);
  for (uint16_t i = 0; i < q.count; ++i)
    r.values.push_back(read_register(c, static_cast<uint16_t>(q.start + i)));
  return r;
}

void write_coil(Controller& c, const modbus::WriteCoilRequest& q) {
  Controller::ControlWrite w{c.control()};
  if (q.coil == lec::address(Coil::SerialMode)) {
    w.flags.serial_mode = q.on();
  } else {
    w.flags.y10_1f = with_bit(w.flags.y10_1f, q.coil - 0x10u, q.on());
    w.svon_written = q.coil == lec::address(Coil::SVON) && q.on();
  }
  c.write_control(w);
}

void write_coils(Controller& c, const modbus::WriteCoilsRequest& q) {
  Controller::ControlWrite w{c.control()};
  for (uint16_t i = 0; i < q.count; ++i) {
    const uint16_t a = static_cast<uint16_t>(q.start + i);
    const bool on = q.bit(i);
    if (a >= 0x10 && a <= 0x1F) {
      w.flags.y10_1f = with_bit(w.flags.y10_1f, a - 0x10u, on);
      if (a == lec::address(Coil::SVON) && on) w.svon_written = true;
    } else if (a == lec::address(Coil::SerialMode)) {
      w.flags.serial_mode = on;
    }
  }
  c.write_control(w);
}

void write_registers(Controller& c, const modbus::WriteRegistersRequest& q) {
  const std::vector<uint16_t> values = q.values();
  std::map<unsigned, lec::StepData> steps;  // touched steps, as the write leaves them
  std::optional<uint16_t> y10;
  std::optional<uint16_t> y30;
  bool start_direct = false;
  for (uint16_t i = 0; i < q.count && i < values.size(); ++i) {
    const uint16_t a = static_cast<uint16_t>(q.start + i);
    const uint16_t v = values[i];
    if (in_range(a, lec::kStepData, lec::kStepCount * lec::kStepStride)) {
      const unsigned off = a - lec::kStepData;
      const unsigned n = off / lec::kStepStride;
      auto it = steps.try_emplace(n, c.eeprom().steps[n]).first;
      auto regs = it->second.to_registers();
      regs[off % lec::kStepStride] = v;
      it->second = lec::StepData::from_registers(std::span<const uint16_t>(regs));
    } else if (in_range(a, lec::kDirectData, Controller::kDirectDataRegisters)) {
      c.write_direct_data(a - lec::kDirectData, v);
    } else if (a == lec::kControlWordY10) {
      y10 = v;
    } else if (a == lec::kControlWordY30) {
      y30 = v;
    } else if (a == lec::kDirectStart) {
      start_direct = start_direct || v != 0;  // any non-zero write starts (digest §4)
    }
  }
  c.write_steps(steps);
  if (y10 || y30) {
    Controller::ControlWrite w{c.control()};
    if (y10) w.flags.y10_1f = *y10;
    if (y30) w.flags.serial_mode = (*y30 & 1u) != 0;
    w.svon_written = y10 && ((*y10 >> 9) & 1u);
    c.write_control(w);
  }
  if (start_direct) c.start_direct();
}

}  // namespace

modbus::Response Controller::handle(const modbus::Request& request, TimePoint t) {
  advance(t);
  const FunctionCode fc = modbus::function_of(request);
  if (auto refusal = lec::check_request(request, control().serial_mode)) {
    return modbus::ExceptionResponse{fc, static_cast<uint8_t>(fc), refusal->code};
  }
  modbus::Response reply = std::visit(
      [&](const auto& q) -> modbus::Response {
        using T = std::decay_t<decltype(q)>;
        if constexpr (std::is_same_v<T, modbus::ReadBitsRequest>) {
          return read_bits(*this, q);
        } else if constexpr (std::is_same_v<T, modbus::ReadRegistersRequest>) {
          return read_registers(*this, q);
        } else if constexpr (std::is_same_v<T, modbus::WriteCoilRequest>) {
          write_coil(*this, q);
          return modbus::WriteCoilResponse{q.coil, q.value};
        } else if constexpr (std::is_same_v<T, modbus::EchoRequest>) {
          return modbus::EchoResponse{q.test_code, q.data};
        } else if constexpr (std::is_same_v<T, modbus::WriteCoilsRequest>) {
          write_coils(*this, q);
          return modbus::WriteMultipleResponse{FunctionCode::WriteCoils, q.start, q.count};
        } else {
          write_registers(*this, q);
          return modbus::WriteMultipleResponse{FunctionCode::WriteRegisters, q.start, q.count};
        }
      },
      request);
  // Events due at this very instant (a zero SVRE delay, a zero-length move).
  advance(now());
  return reply;
}

}  // namespace lec6::sim
