#include "cycles/cycles_config.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <set>

#include "cycles/served_cycle.hpp"
#include "lec6/cycle/cycle_file.hpp"

namespace lec6::serve {
namespace {

std::string mm_of(int32_t v) {
  return fmt::format("{:.2f} mm", v / 100.0);
}

std::string list_lines(const ServeConfig& c) {
  std::string out;
  for (const LineConfig& l : c.lines)
    out += fmt::format("{}{} ({})", out.empty() ? "" : ", ", l.name, l.port);
  return out;
}

std::string list_axes(const LineConfig& l) {
  std::string out;
  for (const AxisConfig& a : l.axes)
    out += fmt::format("{}{} (ID {})", out.empty() ? "" : ", ", a.name, a.id);
  return out;
}

[[noreturn]] void refuse(const cycle::Cycle& c, const cycle::Axis& a, const std::string& field,
                         const std::string& rule) {
  throw cycle::CycleError(c.source, a.mark, field, rule);
}

// Where the cycle's axis `a` is among lec serve's (served_cycle.hpp), and
// its soft limits within lec serve's for that axis.
ServedCycle::Axis match_axis(const ServeConfig& config, cycle::Cycle& c, cycle::Axis& a) {
  const LineConfig* line = nullptr;
  const std::string at = "axes." + a.name;
  if (a.line.empty()) {
    if (config.lines.size() != 1) {
      refuse(c, a, at,
             fmt::format("lec serve has {} lines ({}): say which with line: (its name or port)",
                         config.lines.size(), list_lines(config)));
    }
    line = &config.lines.front();
  } else {
    for (const LineConfig& l : config.lines) {
      if (l.name == a.line || l.port == a.line) line = &l;
    }
    if (!line) {
      refuse(c, a, at + ".line",
             fmt::format("lec serve has no line '{}' (its lines: {})", a.line, list_lines(config)));
    }
  }
  const auto it = std::find_if(line->axes.begin(), line->axes.end(),
                               [&](const AxisConfig& x) { return x.id == a.id; });
  if (it == line->axes.end()) {
    refuse(c, a, at,
           fmt::format("lec serve has no axis with ID {} on line {} (its axes there: {})", a.id,
                       line->name, list_axes(*line)));
  }
  if (const auto& l = it->soft_limits_001mm) {
    // lec serve's limits hold for the cycle's moves too: a named point beyond
    // them is refused now, any other target when its move comes.
    for (const auto& [point, v] : a.points_001mm) {
      if (v < l->first || v > l->second) {
        refuse(c, a, at + ".points." + point,
               fmt::format("{} is beyond lec serve's soft limits of {} ({} to {})", mm_of(v),
                           it->name, mm_of(l->first), mm_of(l->second)));
      }
    }
    client::SoftLimits within{l->first, l->second};
    if (a.soft_limits) {
      within.min_001mm = std::max(within.min_001mm, a.soft_limits->min_001mm);
      within.max_001mm = std::min(within.max_001mm, a.soft_limits->max_001mm);
    }
    a.soft_limits = within;
  }
  return {line->name, a.id, it->name};
}

// Reads one cycle file into config.cycles; throws CycleError.
void add_cycle(ServeConfig& config, const std::filesystem::path& file) {
  auto served = std::make_shared<ServedCycle>();
  served->cycle = cycle::load_cycle(file.string());
  served->file = file;
  cycle::Cycle& c = served->cycle;
  const bool name_ok = !c.name.empty() && c.name.size() <= 64 &&
                       std::all_of(c.name.begin(), c.name.end(), [](unsigned char ch) {
                         return std::isalnum(ch) || ch == '-' || ch == '_';
                       });
  if (!name_ok) {
    throw cycle::CycleError(c.source, {}, "cycle",
                            fmt::format("'{}': lec serve's cycle names are 1 to 64 letters, "
                                        "digits, '-' or '_' (they appear in URLs)",
                                        c.name));
  }
  for (const auto& other : config.cycles) {
    if (other->name() == c.name) {
      throw cycle::CycleError(
          c.source, {}, "cycle",
          fmt::format("'{}' is already the name of the cycle in {}", c.name, other->file.string()));
    }
  }
  std::set<std::string> taken;  // one cycle axis per axis of lec serve
  for (cycle::Axis& a : c.axes) {
    ServedCycle::Axis m = match_axis(config, c, a);
    if (!taken.insert(m.serve_name).second) {
      refuse(c, a, "axes." + a.name,
             fmt::format("{} (ID {} on {}) is another axis of this cycle too", m.serve_name, m.id,
                         m.line));
    }
    served->axes.emplace(a.name, std::move(m));
  }
  config.cycles.push_back(std::move(served));
}

// The cycle files at `path`: the file itself, or a directory's *.yaml and
// *.yml in name order.
std::vector<std::filesystem::path> files_at(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_directory(path, ec)) return {path};
  std::vector<std::filesystem::path> out;
  for (const auto& e : std::filesystem::directory_iterator(path, ec)) {
    const auto ext = e.path().extension();
    if (e.is_regular_file() && (ext == ".yaml" || ext == ".yml")) out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

void read_cycles(const Reader& r, const YAML::Node& n, ServeConfig& config) {
  if (!n || n.IsNull()) return;
  const std::filesystem::path base = std::filesystem::path(r.source()).parent_path();
  const auto one = [&](const YAML::Node& item, const std::string& path) {
    if (!item.IsScalar() || item.Scalar().empty())
      r.fail(item, path, "expected a cycle file or a directory of them (docs/cycles.md)");
    const std::filesystem::path given(item.Scalar());
    const auto files = files_at(given.is_absolute() ? given : base / given);
    if (files.empty()) r.fail(item, path, fmt::format("no *.yaml file in {}", item.Scalar()));
    for (const auto& f : files) {
      try {
        add_cycle(config, f);
      } catch (const InvalidArgument& e) {
        r.fail(item, path, e.what());
      }
    }
  };
  if (n.IsSequence()) {
    for (std::size_t i = 0; i < n.size(); ++i) one(n[i], fmt::format("cycles[{}]", i));
  } else {
    one(n, "cycles");
  }
}

void add_cycles(ServeConfig& config, const std::filesystem::path& path) {
  const auto files = files_at(path);
  if (files.empty()) throw ConfigError(fmt::format("--cycles {}: no *.yaml file", path.string()));
  const std::size_t before = config.cycles.size();
  for (const auto& f : files) {
    try {
      add_cycle(config, f);
    } catch (const InvalidArgument& e) {
      config.cycles.resize(before);  // all of them, or none
      throw ConfigError(fmt::format("--cycles: {}", e.what()));
    }
  }
}

}  // namespace lec6::serve
