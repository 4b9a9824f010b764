// Hex text for frames: what traces print and what `lec raw` / `lec decode` read.

#include <fmt/format.h>

#include <cctype>

#include "lec6/modbus/pdu.hpp"

namespace lec6::modbus {

std::string to_hex(std::span<const uint8_t> bytes) {
  std::string out;
  out.reserve(bytes.size() * 3);
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (i) out.push_back(' ');
    fmt::format_to(std::back_inserter(out), "{:02X}", bytes[i]);
  }
  return out;
}

Expected<Bytes, std::string> from_hex(std::string_view text) {
  Bytes out;
  int pending = -1;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '0' && i + 1 < text.size() && (text[i + 1] == 'x' || text[i + 1] == 'X') &&
        pending < 0) {
      ++i;  // "0x" prefix
      continue;
    }
    if (std::isspace(static_cast<unsigned char>(c)) || c == ',' || c == ':' || c == '-') {
      if (pending >= 0)
        return unexpected(fmt::format("'{}' has a lone hex digit before position {}", text, i));
      continue;
    }
    if (!std::isxdigit(static_cast<unsigned char>(c))) {
      return unexpected(fmt::format("'{}' is not hex: unexpected '{}' at position {}", text, c, i));
    }
    const int v =
        std::isdigit(static_cast<unsigned char>(c)) ? c - '0' : (std::tolower(c) - 'a' + 10);
    if (pending < 0) {
      pending = v;
    } else {
      out.push_back(static_cast<uint8_t>(pending * 16 + v));
      pending = -1;
    }
  }
  if (pending >= 0) return unexpected(fmt::format("'{}' has an odd number of hex digits", text));
  return out;
}

}  // namespace lec6::modbus
