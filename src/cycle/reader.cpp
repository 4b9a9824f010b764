#include "reader.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "lec6/lec/nearest.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::cycle::detail {

Mark Reader::mark(const YAML::Node& n) {
  if (!n.IsDefined()) return {};
  const YAML::Mark m = n.Mark();
  if (m.line < 0) return {};
  return {m.line + 1, m.column + 1};
}

void Reader::fail(const YAML::Node& at, const std::string& field, const std::string& rule) const {
  throw CycleError(source_, mark(at), field, rule);
}

std::string Reader::unknown(std::string_view what, const std::string& word,
                            const std::vector<std::string>& known, std::string_view list_name) {
  const auto hint = lec::nearest(word, known);
  if (hint) return fmt::format("unknown {} '{}': did you mean '{}'?", what, word, *hint);
  std::string list;
  for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
  return fmt::format("unknown {} '{}' ({}: {})", what, word, list_name,
                     list.empty() ? "none" : list);
}

void Reader::keys(const YAML::Node& map, const std::string& field,
                  std::initializer_list<const char*> allowed) const {
  if (!map.IsMap()) fail(map, field, "expected a map of settings");
  const std::vector<std::string> known(allowed.begin(), allowed.end());
  for (const auto& kv : map) {
    const std::string key = kv.first.as<std::string>();
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    fail(kv.first, field.empty() ? key : field + "." + key,
         unknown("key", key, known, "known here"));
  }
}

std::string Reader::text(const YAML::Node& n, const std::string& field) const {
  if (!n.IsScalar()) fail(n, field, "expected a value, not a list or a map");
  return n.Scalar();
}

bool Reader::boolean(const YAML::Node& n, const std::string& field) const {
  const std::string t = text(n, field);
  if (t == "true" || t == "on" || t == "yes" || t == "1") return true;
  if (t == "false" || t == "off" || t == "no" || t == "0") return false;
  fail(n, field, fmt::format("'{}' is not true or false", t));
}

int64_t Reader::integer(const YAML::Node& n, const std::string& field, int64_t min,
                        int64_t max) const {
  const std::string t = text(n, field);
  const auto v = lec::parse_integer(t);
  if (!v) fail(n, field, fmt::format("'{}' is not a whole number", t));
  if (*v < min || *v > max) fail(n, field, fmt::format("{} is outside {} to {}", *v, min, max));
  return *v;
}

int32_t Reader::mm(const YAML::Node& n, const std::string& field) const {
  const std::string t = text(n, field);
  const auto v = lec::parse_mm(t);
  if (!v) fail(n, field, v.error());
  return static_cast<int32_t>(*v);
}

int64_t Reader::step_field(const YAML::Node& n, const std::string& field, lec::StepField f) const {
  const auto v = lec::parse_field(f, text(n, field));
  if (!v) fail(n, field, v.error());
  return *v;
}

Duration Reader::duration(const YAML::Node& n, const std::string& field) const {
  const std::string t = text(n, field);
  std::size_t used = 0;
  double value = 0;
  try {
    value = std::stod(t, &used);
  } catch (const std::exception&) {
    fail(n, field, fmt::format("'{}' is not a duration (e.g. 500ms, 2s, 1min)", t));
  }
  std::string unit = t.substr(used);
  unit.erase(std::remove(unit.begin(), unit.end(), ' '), unit.end());
  double seconds = 0;
  if (unit.empty() || unit == "s") {
    seconds = value;
  } else if (unit == "ms") {
    seconds = value / 1000.0;
  } else if (unit == "min") {
    seconds = value * 60.0;
  } else {
    fail(n, field, fmt::format("'{}': the unit is ms, s or min", t));
  }
  if (!std::isfinite(seconds) || seconds <= 0 || seconds > 24 * 3600.0) {
    fail(n, field, fmt::format("'{}' is not between 0 and 24 hours", t));
  }
  return to_duration(FractionalSeconds(seconds));
}

}  // namespace lec6::cycle::detail
