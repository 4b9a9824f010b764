// Teach-in: one point written into a cycle file's text where the parser says
// it is (include/lec6/cycle/teach.hpp). Our own text edit, not a YAML
// emitter: yaml-cpp would rewrite the whole file and drop its comments.

#include "lec6/cycle/teach.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <vector>

#include "lec6/client/actuator.hpp"
#include "lec6/cycle/cycle_file.hpp"
#include "lec6/lec/units.hpp"
#include "reader.hpp"

namespace lec6::cycle {
namespace {

using detail::Reader;

struct TeachTarget {
  const Axis* axis = nullptr;
  std::string point;
};

bool plain_name(const std::string& s) {
  if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
  });
}

std::vector<std::string> teach_axis_names(const Cycle& c) {
  std::vector<std::string> names;
  for (const auto& a : c.axes) names.push_back(a.name);
  return names;
}

TeachTarget resolve(const Cycle& c, const std::string& source, const std::string& target) {
  TeachTarget t;
  const auto dot = target.find('.');
  if (dot != std::string::npos) {
    const std::string axis = target.substr(0, dot);
    t.point = target.substr(dot + 1);
    for (const auto& a : c.axes)
      if (a.name == axis) t.axis = &a;
    if (!t.axis)
      throw CycleError(source, {}, "axes",
                       Reader::unknown("axis", axis, teach_axis_names(c), "axes"));
    if (!plain_name(t.point))
      throw CycleError(source, t.axis->mark, fmt::format("axes.{}.points", axis),
                       fmt::format("'{}' is not a point name: letters, digits, _ and -, "
                                   "starting with a letter",
                                   t.point));
    return t;
  }
  t.point = target;
  std::vector<const Axis*> with;
  for (const auto& a : c.axes)
    if (a.points_001mm.count(target)) with.push_back(&a);
  if (with.size() == 1) {
    t.axis = with.front();
    return t;
  }
  if (with.empty()) {
    std::string list;
    for (const auto& a : c.axes) list += (list.empty() ? "" : ", ") + a.name;
    throw CycleError(source, {}, "points",
                     fmt::format("no axis has a point '{}': name it AXIS.{} to add it to one "
                                 "(axes: {})",
                                 target, target, list));
  }
  std::string both;
  for (const auto* a : with) both += (both.empty() ? "" : " or ") + a->name + "." + target;
  throw CycleError(source, {}, "points",
                   fmt::format("several axes have a point '{}': name one, {}", target, both));
}

// "50", "12.5", "-3.25": a position as an engineer writes it.
std::string mm_text(int32_t v) {
  std::string s = lec::format_mm(v);
  if (s.find('.') != std::string::npos) {
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  return s;
}

std::size_t pos_of(const YAML::Node& n) {
  return static_cast<std::size_t>(std::max(0, n.Mark().pos));
}

// The end of a plain scalar starting at `from` (a number, an ID).
std::size_t scalar_end(std::string_view text, std::size_t from) {
  std::size_t e = from;
  while (e < text.size() && std::string_view(",}]\n\r#").find(text[e]) == std::string_view::npos)
    ++e;
  while (e > from && (text[e - 1] == ' ' || text[e - 1] == '\t')) --e;
  return e;
}

// The } closing the flow map opening at `open`.
std::size_t flow_end(std::string_view text, std::size_t open, const std::string& source,
                     const Axis& axis) {
  int depth = 0;
  for (std::size_t i = open; i < text.size(); ++i) {
    if (text[i] == '{') ++depth;
    if (text[i] == '}' && --depth == 0) return i;
  }
  throw CycleError(source, axis.mark, fmt::format("axes.{}", axis.name),
                   "a flow map ({...}) without its closing }");
}

std::size_t line_start(std::string_view text, std::size_t pos) {
  while (pos > 0 && text[pos - 1] != '\n') --pos;
  return pos;
}

std::size_t line_end(std::string_view text, std::size_t pos) {
  while (pos < text.size() && text[pos] != '\n') ++pos;
  return pos;
}

// Inserts "name: value" into the map `m` (flow or block), as its last entry.
std::string add_entry(std::string_view text, const YAML::Node& m, const std::string& entry,
                      const std::string& source, const Axis& axis) {
  std::string out(text);
  const std::size_t at = pos_of(m);
  if (at < text.size() && text[at] == '{') {
    const std::size_t close = flow_end(text, at, source, axis);
    std::size_t last = close;
    while (last > at + 1 && std::isspace(static_cast<unsigned char>(text[last - 1]))) --last;
    out.insert(last, last == at + 1 ? entry : ", " + entry);
    return out;
  }
  // Block: after the line of its last value, indented as its first key.
  std::size_t indent = 0, last = at;
  bool first = true;
  for (const auto& kv : m) {
    if (first) indent = static_cast<std::size_t>(std::max(0, kv.first.Mark().column));
    first = false;
    last = std::max({last, pos_of(kv.first), pos_of(kv.second)});
  }
  const std::size_t end = line_end(text, last);
  out.insert(end, "\n" + std::string(indent, ' ') + entry);
  return out;
}

int line_of(std::string_view text, std::size_t pos) {
  return 1 +
         static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(pos), '\n'));
}

}  // namespace

std::string teach_axis(std::string_view text, const std::string& source,
                       const std::string& target) {
  const Cycle c = parse_cycle(text, source);
  return resolve(c, source, target).axis->name;
}

TaughtPoint teach_point(std::string_view text, const std::string& source, const std::string& target,
                        int32_t position_001mm) {
  const Cycle c = parse_cycle(text, source);  // the file as it is must be valid
  const TeachTarget t = resolve(c, source, target);
  const Axis& axis = *t.axis;
  const std::string field = fmt::format("axes.{}.points.{}", axis.name, t.point);
  if (axis.soft_limits) {
    if (client::soft_limit_violation(*axis.soft_limits, position_001mm)) {
      throw CycleError(
          source, axis.mark, field,
          fmt::format("{} mm is outside the axis's soft limits {} to {} mm; "
                      "nothing written",
                      lec::format_mm(position_001mm), lec::format_mm(axis.soft_limits->min_001mm),
                      lec::format_mm(axis.soft_limits->max_001mm)));
    }
  }
  const YAML::Node root = YAML::Load(std::string(text));
  const YAML::Node a = root["axes"][axis.name];
  const std::string value = mm_text(position_001mm);
  const std::string entry = t.point + ": " + value;
  TaughtPoint out;
  out.axis = axis.name;
  out.point = t.point;
  out.position_001mm = position_001mm;
  if (const auto it = axis.points_001mm.find(t.point); it != axis.points_001mm.end())
    out.was_001mm = it->second;

  if (a.IsScalar()) {  // x: 1 → x: {id: 1, points: {name: MM}}
    const std::size_t from = pos_of(a);
    const std::size_t to = scalar_end(text, from);
    out.text = std::string(text);
    out.text.replace(
        from, to - from,
        fmt::format("{{id: {}, points: {{{}}}}}", text.substr(from, to - from), entry));
  } else if (const YAML::Node points = a["points"]) {
    if (const YAML::Node v = points[t.point]) {
      const std::size_t from = pos_of(v);
      out.text = std::string(text);
      out.text.replace(from, scalar_end(text, from) - from, value);
    } else {
      out.text = add_entry(text, points, entry, source, axis);
    }
  } else if (pos_of(a) < text.size() && text[pos_of(a)] == '{') {
    out.text = std::string(text);
    out.text.insert(pos_of(a) + 1, fmt::format("points: {{{}}}, ", entry));
  } else {  // a block map: a line of its own before its first key
    std::size_t indent = 0;
    for (const auto& kv : a) {
      indent = static_cast<std::size_t>(std::max(0, kv.first.Mark().column));
      break;
    }
    out.text = std::string(text);
    out.text.insert(line_start(text, pos_of(a)),
                    std::string(indent, ' ') + fmt::format("points: {{{}}}\n", entry));
  }

  // Read again: the edit must give a valid cycle with the point at its value.
  Cycle again;
  try {
    again = parse_cycle(out.text, source);
  } catch (const CycleError& e) {
    throw CycleError(source, axis.mark, field,
                     fmt::format("the file could not be edited in place ({}); nothing written; "
                                 "write the point by hand",
                                 e.what()));
  }
  for (const auto& b : again.axes) {
    if (b.name != axis.name) continue;
    const auto it = b.points_001mm.find(t.point);
    if (it == b.points_001mm.end() || it->second != position_001mm)
      throw CycleError(source, axis.mark, field,
                       "the file could not be edited in place; nothing written; write the point "
                       "by hand");
  }
  const YAML::Node after = YAML::Load(out.text)["axes"][axis.name]["points"][t.point];
  out.line = line_of(out.text, pos_of(after));
  return out;
}

}  // namespace lec6::cycle
