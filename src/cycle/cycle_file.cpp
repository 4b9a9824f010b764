// The cycle file's top level: name, repeat, axes (with points, soft limits
// and the twin's workpiece), interlocks, branches and steps.

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>

#include "lec6/cycle/cycle_file.hpp"
#include "lec6/lec/units.hpp"
#include "reader.hpp"

namespace lec6::cycle {

using detail::Reader;

namespace {

std::string where(const std::string& file, Mark at) {
  if (at.line <= 0) return file;
  return fmt::format("{}:{}:{}", file, at.line, at.column);
}

void read_axis(const Reader& r, const std::string& name, const YAML::Node& n, Cycle& c) {
  const std::string f = "axes." + name;
  if (n.IsScalar()) {  // x: 1 (just the ID)
    Axis a;
    a.name = name;
    a.id = static_cast<uint8_t>(r.integer(n, f, 1, 247));
    a.mark = Reader::mark(n);
    c.axes.push_back(std::move(a));
    return;
  }
  r.keys(n, f, {"id", "line", "points", "soft_limits", "twin"});
  Axis a;
  a.name = name;
  a.mark = Reader::mark(n);
  if (!n["id"]) r.fail(n, f + ".id", "every axis needs its controller ID (1-247)");
  a.id = static_cast<uint8_t>(r.integer(n["id"], f + ".id", 1, 247));
  if (n["line"]) a.line = r.text(n["line"], f + ".line");
  if (const auto& l = n["soft_limits"]) {
    if (!l.IsSequence() || l.size() != 2) {
      r.fail(l, f + ".soft_limits", "expected [MIN, MAX] in mm, e.g. [0, 400]");
    }
    const int32_t lo = r.mm(l[0], f + ".soft_limits[0]");
    const int32_t hi = r.mm(l[1], f + ".soft_limits[1]");
    if (lo >= hi) r.fail(l, f + ".soft_limits", "MIN must be below MAX");
    a.soft_limits = client::SoftLimits{lo, hi};
  }
  if (const auto& p = n["points"]) {
    if (!p.IsMap()) r.fail(p, f + ".points", "expected a map of NAME: MM");
    for (const auto& kv : p) {
      const std::string pname = kv.first.as<std::string>();
      const std::string pf = f + ".points." + pname;
      const int32_t v = r.mm(kv.second, pf);
      if (a.soft_limits) {
        if (auto why = client::soft_limit_violation(*a.soft_limits, v)) {
          r.fail(kv.second, pf,
                 fmt::format("{} mm is outside the axis's soft limits {} to {} mm",
                             lec::format_mm(v), lec::format_mm(a.soft_limits->min_001mm),
                             lec::format_mm(a.soft_limits->max_001mm)));
        }
      }
      a.points_001mm[pname] = v;
    }
  }
  if (const auto& t = n["twin"]) {
    r.keys(t, f + ".twin", {"workpiece_mm"});
    if (t["workpiece_mm"])
      a.twin_workpiece_mm = r.mm(t["workpiece_mm"], f + ".twin.workpiece_mm") / 100.0;
  }
  for (const auto& other : c.axes) {
    if (other.line == a.line && other.id == a.id) {
      r.fail(n["id"], f + ".id",
             fmt::format("ID {} is also axis '{}' on the same line (line {})", a.id, other.name,
                         other.mark.line));
    }
  }
  c.axes.push_back(std::move(a));
}

std::vector<std::string> axis_names(const Cycle& c) {
  std::vector<std::string> names;
  for (const auto& a : c.axes) names.push_back(a.name);
  return names;
}

void read_interlock(const Reader& r, const YAML::Node& n, const std::string& f, Cycle& c) {
  r.keys(n, f, {"before_moving", "axis", "above_mm", "below_mm"});
  UserInterlock u;
  u.mark = Reader::mark(n);
  for (const char* key : {"before_moving", "axis"}) {
    if (!n[key]) r.fail(n, f + "." + key, "an interlock names before_moving and axis");
    const std::string name = r.text(n[key], f + "." + key);
    if (!c.axis(name))
      r.fail(n[key], f + "." + key, Reader::unknown("axis", name, axis_names(c), "axes"));
    (std::string_view(key) == "axis" ? u.axis : u.before_moving) = name;
  }
  if (static_cast<bool>(n["above_mm"]) == static_cast<bool>(n["below_mm"])) {
    r.fail(n, f, "give exactly one of above_mm or below_mm");
  }
  const Axis& a = *c.axis(u.axis);
  if (n["above_mm"]) {
    u.above_001mm = r.mm(n["above_mm"], f + ".above_mm");
    if (a.soft_limits && *u.above_001mm >= a.soft_limits->max_001mm) {
      r.fail(n["above_mm"], f + ".above_mm",
             fmt::format("axis {} can never be above {} mm (soft limits up to {} mm)", u.axis,
                         lec::format_mm(*u.above_001mm), lec::format_mm(a.soft_limits->max_001mm)));
    }
  } else {
    u.below_001mm = r.mm(n["below_mm"], f + ".below_mm");
    if (a.soft_limits && *u.below_001mm <= a.soft_limits->min_001mm) {
      r.fail(n["below_mm"], f + ".below_mm",
             fmt::format("axis {} can never be below {} mm (soft limits from {} mm)", u.axis,
                         lec::format_mm(*u.below_001mm), lec::format_mm(a.soft_limits->min_001mm)));
    }
  }
  u.text =
      fmt::format("{} {} {} mm before {} moves", u.axis, u.above_001mm ? "above" : "below",
                  lec::format_mm(u.above_001mm ? *u.above_001mm : *u.below_001mm), u.before_moving);
  c.interlocks.push_back(std::move(u));
}

// A branch that can reach itself would never end.
void refuse_recursive_branches(const Reader& r, const YAML::Node& branches, const Cycle& c) {
  std::function<void(const std::vector<Step>&, std::set<std::string>&, std::vector<std::string>&)>
      visit;
  std::function<void(const std::string&, std::vector<std::string>&)> enter;
  enter = [&](const std::string& name, std::vector<std::string>& path) {
    if (std::find(path.begin(), path.end(), name) != path.end()) {
      std::string chain;
      for (const auto& p : path) chain += p + " -> ";
      r.fail(branches[path.front()], "branches." + path.front(),
             fmt::format("the branch can call itself ({}{}): it would never end", chain, name));
    }
    path.push_back(name);
    std::set<std::string> unused;
    visit(c.branches.at(name), unused, path);
    path.pop_back();
  };
  visit = [&](const std::vector<Step>& steps, std::set<std::string>& s,
              std::vector<std::string>& path) {
    for (const auto& step : steps) {
      for (const auto& [outcome, target] : step.on) {
        if (target.kind == Target::Branch) enter(target.branch, path);
      }
      visit(step.steps, s, path);
    }
  };
  for (const auto& [name, steps] : c.branches) {
    std::vector<std::string> path;
    enter(name, path);
  }
}

}  // namespace

CycleError::CycleError(std::string file, Mark at, std::string field, std::string rule)
    : InvalidArgument(field.empty() ? fmt::format("{}: {}", where(file, at), rule)
                                    : fmt::format("{}: {}: {}", where(file, at), field, rule)),
      file_(std::move(file)),
      at_(at),
      field_(std::move(field)),
      rule_(std::move(rule)) {}

const Axis* Cycle::axis(std::string_view name) const {
  for (const auto& a : axes) {
    if (a.name == name) return &a;
  }
  return nullptr;
}

Cycle parse_cycle(std::string_view yaml_text, const std::string& source) {
  const Reader r(source);
  YAML::Node root;
  try {
    root = YAML::Load(std::string(yaml_text));
  } catch (const YAML::ParserException& e) {
    throw CycleError(source, {e.mark.line + 1, e.mark.column + 1}, "", "not valid YAML: " + e.msg);
  }
  if (!root.IsMap()) r.fail(root, "", "a cycle file is a map with axes and steps (docs/cycles.md)");
  r.keys(root, "", {"cycle", "repeat", "axes", "interlocks", "steps", "branches", "faults"});
  Cycle c;
  c.source = source;
  c.name = root["cycle"] ? r.text(root["cycle"], "cycle") : std::string("cycle");
  if (root["repeat"])
    c.repeat = static_cast<unsigned>(r.integer(root["repeat"], "repeat", 1, 1000000));
  const auto& axes = root["axes"];
  if (!axes || !axes.IsMap() || axes.size() == 0) {
    r.fail(axes ? axes : root, "axes", "a cycle names its axes: axes: {x: {id: 1}, ...}");
  }
  for (const auto& kv : axes) read_axis(r, kv.first.as<std::string>(), kv.second, c);
  if (const auto& il = root["interlocks"]) {
    if (!il.IsSequence()) r.fail(il, "interlocks", "expected a list of interlocks");
    for (std::size_t i = 0; i < il.size(); ++i) {
      read_interlock(r, il[i], fmt::format("interlocks[{}]", i), c);
    }
  }
  std::vector<std::string> branch_names;
  const auto& branches = root["branches"];
  if (branches) {
    if (!branches.IsMap()) r.fail(branches, "branches", "expected a map of NAME: [steps]");
    for (const auto& kv : branches) {
      const std::string name = kv.first.as<std::string>();
      if (name == "abort" || name == "continue") {
        r.fail(kv.first, "branches." + name, "'abort' and 'continue' are not branch names");
      }
      // A step's path is BRANCH.N (faults: step: no_part.1): a dot would
      // split it, and a name of digits would read as a step number.
      if (name.find('.') != std::string::npos ||
          name.find_first_not_of("0123456789") == std::string::npos) {
        r.fail(
            kv.first, "branches." + name,
            "a branch name has no '.' and is not a number (its steps are BRANCH.1, BRANCH.2, ...)");
      }
      branch_names.push_back(name);
    }
  }
  if (!root["steps"]) r.fail(root, "steps", "a cycle has steps");
  c.steps = detail::read_steps(r, root["steps"], "steps", c, branch_names);
  if (branches) {
    for (const auto& kv : branches) {
      const std::string name = kv.first.as<std::string>();
      c.branches[name] = detail::read_steps(r, kv.second, "branches." + name, c, branch_names);
    }
    refuse_recursive_branches(r, branches, c);
  }
  if (const auto& f = root["faults"]) {  // last: a fault names steps and branches
    if (!f.IsSequence()) r.fail(f, "faults", "expected a list of faults (docs/cycles.md)");
    for (std::size_t i = 0; i < f.size(); ++i) {
      c.faults.push_back(detail::read_fault(r, f[i], fmt::format("faults[{}]", i), c));
    }
  }
  return c;
}

Cycle load_cycle(const std::string& path) {
  // The OS's reason, in the user's terms: a missing file, a directory and a
  // file without read permission are three different mistakes.
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw CycleError(path, {}, "", "cannot read the file: it is a directory, not a cycle file");
  }
  errno = 0;
  std::ifstream in(path);
  if (!in) {
    const int err = errno;
    throw CycleError(
        path, {}, "",
        fmt::format("cannot read the file: {}", err ? std::strerror(err) : "not readable"));
  }
  std::stringstream text;
  text << in.rdbuf();
  return parse_cycle(text.str(), path);
}

}  // namespace lec6::cycle
