#include "lec6/lec/explain.hpp"

#include <fmt/format.h>

#include "lec6/lec/flags.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/lec/step_data.hpp"
#include "lec6/lec/units.hpp"
#include "lec6/lec/words.hpp"

namespace lec6::lec {
namespace {

using namespace modbus;

std::string id_text(uint8_t id) {
  return id == kBroadcastId ? "broadcast" : fmt::format("ID {}", id);
}

std::string bit_range(Space s, uint16_t start, uint16_t count) {
  const char letter = s == Space::Coil ? 'Y' : 'X';
  if (count == 1) return address_name(s, start);
  return fmt::format("{}{:02X}–{}{:02X}", letter, start, letter, start + count - 1);
}

std::string bits_text(Space s, uint16_t start, uint16_t count, const Bytes& packed) {
  std::string on;
  for (uint16_t i = 0; i < count; ++i) {
    if (!((i / 8u < packed.size()) && ((packed[i / 8u] >> (i % 8u)) & 1U))) continue;
    if (!on.empty()) on += ' ';
    const std::string name = address_name(s, static_cast<uint16_t>(start + i));
    const auto space = name.find(' ');
    on += space == std::string::npos ? name : name.substr(space + 1);
  }
  return on.empty() ? "all 0" : on + " = 1";
}

// Values of the registers from `start`, named where the map names them.
std::string registers_text(uint16_t start, const std::vector<uint16_t>& values) {
  std::string out;
  auto add = [&](const std::string& s) { out += out.empty() ? s : ", " + s; };
  for (std::size_t i = 0; i < values.size(); ++i) {
    const auto a = static_cast<uint16_t>(start + i);
    const bool step = a >= kStepData && a <= 0x07FF;
    const bool direct = a >= kDirectData && a <= 0x9111;
    if (step || direct) {
      const unsigned off = (a - (step ? kStepData : kDirectData)) % kStepStride;
      const StepFieldInfo* f = nullptr;
      for (const auto& fi : step_fields()) {
        if (fi.offset == off) f = &fi;
      }
      const std::string where =
          step ? fmt::format("step {} ", (a - kStepData) / kStepStride) : "direct ";
      if (f && f->registers == 2 && i + 1 < values.size()) {
        const int32_t v = join_words(values[i], values[i + 1]);
        add(fmt::format("{}{} = {}{}{}", where, f->name, format_field(f->field, v),
                        f->unit.empty() ? "" : " ", f->unit));
        ++i;
        continue;
      }
      if (f && f->registers == 1) {
        add(fmt::format("{}{} = {}{}{}", where, f->name, format_field(f->field, values[i]),
                        f->unit.empty() ? "" : " ", f->unit));
        continue;
      }
    }
    if ((a == 0x9000 || a == 0x9004) && i + 1 < values.size()) {
      const int32_t v = join_words(values[i], values[i + 1]);
      add(fmt::format("{} = {} mm", address_name(Space::Register, a), format_mm(v)));
      ++i;
      continue;
    }
    if (a == kDirectStart) {
      add(values[i] ? fmt::format("D9100 = {:04X}h: start direct operation", values[i])
                    : "D9100 = 0");
      continue;
    }
    if (a == kStatusWord) {
      add(fmt::format("D9084 flags: {}", StatusFlags{values[i]}.describe()));
      continue;
    }
    add(fmt::format("{} = {} ({:04X}h)", address_name(Space::Register, a), values[i], values[i]));
  }
  return out;
}

std::string reg_range(uint16_t start, uint16_t count) {
  if (count == 1) return address_name(Space::Register, start);
  return fmt::format("D{:04X}–D{:04X} ({})", start, start + count - 1, [&] {
    const std::string n = address_name(Space::Register, start);
    const auto sp = n.find(' ');
    return sp == std::string::npos ? std::string("undefined") : n.substr(sp + 1);
  }());
}

}  // namespace

std::string explain_request(const RequestFrame& frame) {
  const std::string who = id_text(frame.id);
  struct Visitor {
    const std::string& who;
    std::string operator()(const ReadBitsRequest& q) const {
      const Space s = q.function == FunctionCode::ReadCoils ? Space::Coil : Space::Input;
      return fmt::format("{} read {} ({} points)", who, bit_range(s, q.start, q.count), q.count);
    }
    std::string operator()(const ReadRegistersRequest& q) const {
      return fmt::format("{} read {} ({} registers)", who, reg_range(q.start, q.count), q.count);
    }
    std::string operator()(const WriteCoilRequest& q) const {
      const char* v = q.value == kCoilOn ? "ON" : q.value == kCoilOff ? "OFF" : "invalid value";
      return fmt::format("{} write {} = {}", who, address_name(Space::Coil, q.coil), v);
    }
    std::string operator()(const EchoRequest& q) const {
      return fmt::format("{} echo test code {:04X}h data {:04X}h", who, q.test_code, q.data);
    }
    std::string operator()(const WriteCoilsRequest& q) const {
      std::string extra;
      if (q.start == address(Coil::IN0) && q.count <= 8) {
        extra = fmt::format(" (select step {})", q.packed.empty() ? 0 : (q.packed[0] & 0x3F));
      }
      return fmt::format("{} write {}: {}{}", who, bit_range(Space::Coil, q.start, q.count),
                         bits_text(Space::Coil, q.start, q.count, q.packed), extra);
    }
    std::string operator()(const WriteRegistersRequest& q) const {
      return fmt::format("{} write {}: {}", who, reg_range(q.start, q.count),
                         registers_text(q.start, q.values()));
    }
  };
  return std::visit(Visitor{who}, frame.pdu);
}

std::string explain_response(const ResponseFrame& frame, const RequestFrame* request) {
  const std::string who = id_text(frame.id);
  struct Visitor {
    const std::string& who;
    const RequestFrame* request;
    std::string operator()(const ReadBitsResponse& a) const {
      const Space s = a.function == FunctionCode::ReadCoils ? Space::Coil : Space::Input;
      uint16_t start = s == Space::Input ? kStatusInputs : address(Coil::IN0);
      auto count = static_cast<uint16_t>(a.packed.size() * 8);
      if (request) {
        if (const auto* q = std::get_if<ReadBitsRequest>(&request->pdu))
          start = q->start, count = q->count;
      }
      return fmt::format("{} {}: {}", who, bit_range(s, start, count),
                         bits_text(s, start, count, a.packed));
    }
    std::string operator()(const ReadRegistersResponse& a) const {
      if (request) {
        if (const auto* q = std::get_if<ReadRegistersRequest>(&request->pdu)) {
          return fmt::format("{} {}", who, registers_text(q->start, a.values));
        }
      }
      std::string words;
      for (uint16_t v : a.values) words += fmt::format("{}{:04X}h", words.empty() ? "" : " ", v);
      return fmt::format("{} {} register(s): {}", who, a.values.size(), words);
    }
    std::string operator()(const WriteCoilResponse& a) const {
      return fmt::format("{} ok: {} = {}", who, address_name(Space::Coil, a.coil),
                         a.value == kCoilOn ? "ON" : "OFF");
    }
    std::string operator()(const EchoResponse& a) const {
      return fmt::format("{} echo reply data {:04X}h", who, a.data);
    }
    std::string operator()(const WriteMultipleResponse& a) const {
      if (a.function == FunctionCode::WriteCoils) {
        return fmt::format("{} ok: wrote {}", who, bit_range(Space::Coil, a.start, a.count));
      }
      return fmt::format("{} ok: wrote {} register(s) at D{:04X}", who, a.count, a.start);
    }
    std::string operator()(const ExceptionResponse& a) const {
      return fmt::format("{} exception {:02X} ({}) to function {:02X}h", who,
                         static_cast<int>(a.code), exception_name(a.code), a.raw_function);
    }
  };
  return std::visit(Visitor{who, request}, frame.pdu);
}

std::string explain_bytes(std::span<const uint8_t> adu, FrameRole role) {
  if (role == FrameRole::Reply) {
    auto r = decode_response(adu);
    return r ? explain_response(*r) : fmt::format("not a valid reply: {}", r.error().message);
  }
  auto q = decode_request(adu);
  return q ? explain_request(*q) : fmt::format("not a valid request: {}", q.error().message);
}

}  // namespace lec6::lec
