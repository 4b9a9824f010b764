#include "lec6/sim/state_file.hpp"

#include <fmt/format.h>

#include <charconv>
#include <vector>

namespace lec6::sim {

namespace {

constexpr std::string_view kMagic = "lec6-twin-state 1";

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && line[i] == ' ') ++i;
    const std::size_t j = line.find(' ', i);
    const std::size_t end = j == std::string_view::npos ? line.size() : j;
    if (end > i) out.push_back(line.substr(i, end - i));
    i = end;
  }
  return out;
}

template <typename T>
bool parse_num(std::string_view s, T& out, int base = 10) {
  if (s.empty()) return false;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), out, base);
  return ec == std::errc() && p == s.data() + s.size();
}

}  // namespace

std::string serialize_state(const EepromSet& state) {
  std::string out(kMagic);
  out += '\n';
  for (const auto& [id, e] : state) {
    out += fmt::format("controller {}\n", id);
    out += fmt::format("name {}\n", e.name.text);
    for (std::size_t n = 0; n < Eeprom::kSteps; ++n) {
      if (e.steps[n].is_blank() && e.step_writes[n] == 0) continue;
      out += fmt::format("step {} writes {}", n, e.step_writes[n]);
      for (uint16_t r : e.steps[n].to_registers()) out += fmt::format(" {:04X}", r);
      out += '\n';
    }
    for (std::size_t g = 0; g < lec::AlarmHistory::kGroups; ++g) {
      if (e.alarms.groups[g].empty()) continue;
      out += fmt::format("alarm {}", g);
      for (uint8_t c : e.alarms.groups[g].codes) out += fmt::format(" {:02X}", c);
      out += '\n';
    }
    out += "end\n";
  }
  return out;
}

Expected<EepromSet, std::string> parse_state(std::string_view text) {
  EepromSet set;
  std::optional<uint8_t> current;
  std::size_t line_no = 0;
  bool magic = false;
  auto fail = [&](std::string_view why) {
    return unexpected(fmt::format("state file line {}: {}", line_no, why));
  };
  while (!text.empty()) {
    const std::size_t nl = text.find('\n');
    std::string_view line = text.substr(0, nl);
    text = nl == std::string_view::npos ? std::string_view{} : text.substr(nl + 1);
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (!magic) {
      if (line != kMagic)
        return fail(fmt::format("expected '{}' (not a twin state file?)", kMagic));
      magic = true;
      continue;
    }
    if (line.empty() || line[0] == '#') continue;
    const auto words = split(line);
    const std::string_view key = words[0];
    if (key == "controller") {
      unsigned id = 0;
      if (current) return fail("'controller' inside another controller (missing 'end')");
      if (words.size() != 2 || !parse_num(words[1], id) || id < 1 || id > 255) {
        return fail("'controller' needs an ID 1–255");
      }
      current = static_cast<uint8_t>(id);
      set[*current] = Eeprom{};
      continue;
    }
    if (!current) return fail(fmt::format("'{}' outside a controller section", key));
    Eeprom& e = set[*current];
    if (key == "end") {
      current.reset();
    } else if (key == "name") {
      const std::string_view rest = line.size() > 5 ? line.substr(5) : std::string_view{};
      auto name = lec::EquipmentName::make(rest);
      if (!name) return fail(name.error());
      e.name = *name;
    } else if (key == "step") {
      unsigned n = 0;
      uint32_t writes = 0;
      if (words.size() != 4 + lec::StepData::kRegisters || !parse_num(words[1], n) ||
          n >= Eeprom::kSteps || words[2] != "writes" || !parse_num(words[3], writes)) {
        return fail("'step' needs: step N writes COUNT and 16 hex registers");
      }
      std::array<uint16_t, lec::StepData::kRegisters> regs{};
      for (std::size_t i = 0; i < regs.size(); ++i) {
        if (!parse_num(words[4 + i], regs[i], 16)) return fail("bad hex register in 'step'");
      }
      e.steps[n] = lec::StepData::from_registers(std::span<const uint16_t>(regs));
      e.step_writes[n] = writes;
    } else if (key == "alarm") {
      unsigned g = 0;
      if (words.size() != 10 || !parse_num(words[1], g) || g >= lec::AlarmHistory::kGroups) {
        return fail("'alarm' needs: alarm GROUP and 8 hex codes");
      }
      for (std::size_t i = 0; i < 8; ++i) {
        if (!parse_num(words[2 + i], e.alarms.groups[g].codes[i], 16))
          return fail("bad hex code in 'alarm'");
      }
    } else {
      return fail(fmt::format("unknown record '{}'", key));
    }
  }
  if (!magic) return unexpected(std::string("state file is empty"));
  if (current)
    return unexpected(std::string("state file ends inside a controller section (missing 'end')"));
  return set;
}

}  // namespace lec6::sim
