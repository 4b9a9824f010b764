#include "cli/sim_args.hpp"

#include <cmath>
#include <set>

#include "cli/app.hpp"

namespace lec6::cli::sim_args {

std::string trim(std::string s) {
  const auto b = s.find_first_not_of(" \t");
  const auto e = s.find_last_not_of(" \t");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

static unsigned parse_one_id(const std::string& text) {
  std::size_t used = 0;
  unsigned long v = 0;
  try {
    v = std::stoul(text, &used, 10);
  } catch (const std::exception&) {
    used = 0;
  }
  if (text.empty() || used != text.size() || v < 1 || v > 255) {
    throw UsageError(fmt::format(
        "--ids: '{}' is not a controller ID (1-255; 0 is the broadcast address)", text));
  }
  return static_cast<unsigned>(v);
}

std::vector<uint8_t> parse_ids(const std::string& text) {
  std::set<unsigned> ids;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t comma = text.find(',', pos);
    const std::string item =
        trim(text.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos));
    if (item.empty()) throw UsageError(fmt::format("--ids: empty item in '{}'", text));
    if (const auto dash = item.find('-'); dash != std::string::npos) {
      const unsigned lo = parse_one_id(trim(item.substr(0, dash)));
      const unsigned hi = parse_one_id(trim(item.substr(dash + 1)));
      if (lo > hi) throw UsageError(fmt::format("--ids: range '{}' runs backwards", item));
      for (unsigned i = lo; i <= hi; ++i) ids.insert(i);
    } else {
      ids.insert(parse_one_id(item));
    }
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  return {ids.begin(), ids.end()};
}

std::string format_ids(const std::vector<uint8_t>& ids) {
  std::string out;
  for (std::size_t i = 0; i < ids.size();) {
    std::size_t j = i;
    while (j + 1 < ids.size() && ids[j + 1] == ids[j] + 1) ++j;
    if (!out.empty()) out += ", ";
    out += j > i ? fmt::format("{}-{}", ids[i], ids[j]) : fmt::format("{}", ids[i]);
    i = j + 1;
  }
  return out;
}

double parse_mm(const std::string& option, const std::string& text) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (text.empty() || used != text.size() || !std::isfinite(v)) {
    throw UsageError(fmt::format("{}: '{}' is not a number of mm", option, text));
  }
  return v;
}

std::pair<std::string, uint16_t> parse_tcp(const std::string& text) {
  const auto colon = text.rfind(':');
  std::string host = colon == std::string::npos ? std::string() : text.substr(0, colon);
  const std::string port_text = colon == std::string::npos ? text : text.substr(colon + 1);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']')
    host = host.substr(1, host.size() - 2);
  if (host.empty()) host = "127.0.0.1";
  std::size_t used = 0;
  unsigned long port = 0;
  try {
    port = std::stoul(port_text, &used, 10);
  } catch (const std::exception&) {
    used = 0;
  }
  if (port_text.empty() || used != port_text.size() || port > 65535) {
    throw UsageError(fmt::format(
        "--tcp: '{}' is not HOST:PORT (port 0-65535, 0 picks a free one; e.g. 127.0.0.1:5020)",
        text));
  }
  return {host, static_cast<uint16_t>(port)};
}

}  // namespace lec6::cli::sim_args
