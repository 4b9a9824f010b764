#include "lec6/lec/units.hpp"

#include <fmt/format.h>

#include <cctype>
#include <charconv>
#include <cstdlib>

namespace lec6::lec {
namespace {
constexpr int64_t kInt32Max = 2147483647;

std::string_view trim_number(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}
}  // namespace

std::string format_mm(int64_t v) {
  const bool negative = v < 0;
  const uint64_t mag = negative ? static_cast<uint64_t>(-(v + 1)) + 1 : static_cast<uint64_t>(v);
  return fmt::format("{}{}.{:02}", negative ? "-" : "", mag / 100, mag % 100);
}

Expected<int64_t, std::string> parse_integer(std::string_view text) {
  const std::string_view t = trim_number(text);
  std::string_view digits = t;
  if (!digits.empty() && digits.front() == '+') digits.remove_prefix(1);
  int64_t v = 0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), v);
  if (digits.empty() || ec != std::errc{} || end != digits.data() + digits.size()) {
    return unexpected(fmt::format("'{}' is not a whole number", text));
  }
  return v;
}

Expected<int64_t, std::string> parse_mm(std::string_view text) {
  std::string_view t = trim_number(text);
  bool negative = false;
  if (!t.empty() && (t.front() == '-' || t.front() == '+')) {
    negative = t.front() == '-';
    t.remove_prefix(1);
  }
  const auto dot = t.find_first_of(".,");  // spreadsheets in some locales write 150,00
  const std::string_view whole = t.substr(0, dot);
  const std::string_view frac =
      dot == std::string_view::npos ? std::string_view{} : t.substr(dot + 1);
  auto all_digits = [](std::string_view s) {
    for (char c : s) {
      if (!std::isdigit(static_cast<unsigned char>(c))) return false;
    }
    return true;
  };
  if ((whole.empty() && frac.empty()) || !all_digits(whole) || !all_digits(frac) ||
      whole.size() > 10) {
    return unexpected(fmt::format("'{}' is not a length in mm (e.g. 150.00)", text));
  }
  if (frac.size() > 2) {
    return unexpected(
        fmt::format("'{}' has more than two decimals: lengths are in 0.01 mm steps", text));
  }
  int64_t mm = 0;
  if (!whole.empty()) std::from_chars(whole.data(), whole.data() + whole.size(), mm);
  int64_t hundredths = 0;
  if (!frac.empty()) {
    std::from_chars(frac.data(), frac.data() + frac.size(), hundredths);
    if (frac.size() == 1) hundredths *= 10;
  }
  int64_t v = mm * 100 + hundredths;
  if (negative) v = -v;
  if (v > kInt32Max || v < -kInt32Max) {
    return unexpected(fmt::format("'{}' mm is outside ±21474836.47 mm", text));
  }
  return v;
}

}  // namespace lec6::lec
