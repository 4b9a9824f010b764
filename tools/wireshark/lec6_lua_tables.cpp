// Prints the tables of tools/wireshark/lec6.lua from the library's own memory
// map (lec::address_name, lec::step_fields), so the dissector names every
// coil, input and register as `lec decode` does, and cannot drift from it:
// integration.wireshark_dissector_test fails when the file's tables differ
// from this program's output; tools/wireshark/update-tables rewrites them.

#include <fmt/format.h>

#include <string>
#include <string_view>

#include "lec6/lec/memory_map.hpp"
#include "lec6/lec/step_data.hpp"

namespace {

using lec6::lec::Space;

// A Lua string literal (the names are plain text, UTF-8 included).
std::string lua_string(std::string_view s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

// The name when the map names the address ("Y19 SVON"); empty for a bare "Y1A".
std::string named(const std::string& name) {
  const auto sp = name.find(' ');
  return sp == std::string::npos ? std::string{} : name;
}

void bits(Space space, const char* table, uint16_t first, uint16_t last) {
  fmt::print("{} = {{\n", table);
  for (unsigned a = first; a <= last; ++a) {
    const std::string n = named(lec6::lec::address_name(space, static_cast<uint16_t>(a)));
    if (!n.empty()) fmt::print("  [0x{:02X}] = {},\n", a, lua_string(n));
  }
  fmt::print("}}\n");
}

// REGISTERS[address] = {name, words, scale, unit, kind}: words 2 joins the
// next register (high word first); scale 100: 0.01 mm shown in mm; kind
// "mode" (movement mode), "bits:X40"/"bits:Y10"/"bits:Y30" (a flags word),
// "start" (D9100).
void registers() {
  fmt::print("REGISTERS = {{\n");
  auto entry = [](unsigned a, int words, int scale, std::string_view unit, std::string_view kind) {
    std::string n = named(lec6::lec::address_name(Space::Register, static_cast<uint16_t>(a)));
    if (n.empty()) return;
    constexpr std::string_view high = " (high word)";  // both words are shown as one value
    if (words == 2 && n.ends_with(high)) n.resize(n.size() - high.size());
    fmt::print("  [0x{:04X}] = {{{}, {}, {}, {}, {}}},\n", a, lua_string(n), words, scale,
               lua_string(unit), lua_string(kind));
  };
  auto record = [&](unsigned base, unsigned last) {
    for (unsigned off = 0; off < lec6::lec::kStepStride && base + off <= last; ++off) {
      const lec6::lec::StepFieldInfo* f = nullptr;
      for (const auto& i : lec6::lec::step_fields())
        if (i.offset == off) f = &i;
      if (f) {
        const bool mode = f->field == lec6::lec::StepField::MovementMode;
        entry(base + off, f->registers, f->is_length ? 100 : 1, f->unit, mode ? "mode" : "");
      } else {
        entry(base + off, 1, 1, "", "");
      }
    }
  };
  for (const auto& area : lec6::lec::areas()) {
    if (area.space != Space::Register) continue;
    for (unsigned a = area.first; a <= area.last; ++a) {
      if (a >= lec6::lec::kStepData && a <= 0x07FF) {
        if ((a - lec6::lec::kStepData) % lec6::lec::kStepStride == 0) record(a, 0x07FF);
        continue;
      }
      if (a >= lec6::lec::kDirectData && a <= area.last) {
        if (a == lec6::lec::kDirectData) record(a, area.last);
        continue;
      }
      switch (a) {
        case lec6::lec::kStateData:  // D9000–D9001, 0.01 mm (state_data.hpp)
        case lec6::lec::kStateData + 4:
          entry(a, 2, 100, "mm", "");
          ++a;
          break;
        case lec6::lec::kStateData + 2:
          entry(a, 1, 1, "mm/s", "");
          break;
        case lec6::lec::kStateData + 3:
          entry(a, 1, 1, "%", "");
          break;
        case lec6::lec::kStatusWord:
          entry(a, 1, 1, "", "bits:X40");
          break;
        case lec6::lec::kControlWordY10:
          entry(a, 1, 1, "", "bits:Y10");
          break;
        case lec6::lec::kControlWordY30:
          entry(a, 1, 1, "", "bits:Y30");
          break;
        case lec6::lec::kDirectStart:
          entry(a, 1, 1, "", "start");
          break;
        default:
          entry(a, 1, 1, "", "");
      }
    }
  }
  fmt::print("}}\n");
}

}  // namespace

int main() {
  fmt::print(
      "-- BEGIN TABLES: generated from lec6's memory map by tools/wireshark/update-tables\n");
  bits(Space::Coil, "COILS", 0x00, 0x3F);
  bits(Space::Input, "INPUTS", 0x40, 0x4F);
  registers();
  fmt::print("-- END TABLES\n");
}
