// `lec cycle check FILE` and `lec cycle run FILE`: machine cycles (issue 34,
// docs/cycles.md). The file is read and checked whole before any port is
// opened; a bad file exits 2 with file:line:column: field: rule.

#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli/app.hpp"
#include "cli/cycle_lines.hpp"
#include "cli/cycle_report.hpp"
#include "cli/duration_option.hpp"
#include "lec6/cycle/cycle_file.hpp"
#include "lec6/cycle/runner.hpp"
#include "lec6/cycle/teach.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::cli {

namespace {

struct CycleArgs {
  std::string file;
  std::string junit;
  std::string profile;
  bool prepare = false;
  Duration max_cycle_time{};
  std::string target;  // teach: AXIS.POINT or POINT
  std::string at;      // teach: the value (mm), instead of the axis's position
};

std::string cycle_port(const GlobalOptions& g) {
  if (!g.port.empty()) return g.port;
  if (const char* env = std::getenv("LEC_PORT"); env && *env) return env;
  return {};
}

void check(const GlobalOptions& g, const CycleArgs& a) {
  const cycle::Cycle c = cycle::load_cycle(a.file);  // CycleError: exit 2
  std::size_t steps = 0;
  std::function<void(const std::vector<cycle::Step>&)> count = [&](const auto& list) {
    for (const auto& s : list) {
      ++steps;
      count(s.steps);
    }
  };
  count(c.steps);
  for (const auto& [name, list] : c.branches) count(list);
  if (g.json) {
    fmt::print("{}\n", nlohmann::json{{"file", a.file},
                                      {"cycle", c.name},
                                      {"valid", true},
                                      {"axes", c.axes.size()},
                                      {"steps", steps},
                                      {"branches", c.branches.size()},
                                      {"interlocks", c.interlocks.size()}}
                           .dump());
    return;
  }
  fmt::print("{}: cycle '{}' is valid: {} axes, {} steps, {} branches, {} interlocks\n", a.file,
             c.name, c.axes.size(), steps, c.branches.size(), c.interlocks.size());
}

// The exit code and, when not 0, the message.
std::pair<int, std::string> run(const GlobalOptions& g, const CycleArgs& a) {
  const cycle::Cycle c = cycle::load_cycle(a.file);  // before any port is opened
  CycleLines lines(c, g, cycle_port(g), a.profile);
  if (lines.simulated() || a.prepare) lines.prepare(c);
  if (!g.json) {
    fmt::print("cycle '{}' on {}\n", c.name, lines.describe());
    std::fflush(stdout);
  }
  cycle::RunOptions o;
  o.stop_requested = [] { return g_interrupted.load(); };
  if (!g.json) {
    o.on_step = [](const cycle::StepReport& s) {
      fmt::print("{}", format_step(s));
      std::fflush(stdout);
    };
  }
  cycle::Runner runner(c, lines.clients(), o);
  const cycle::CycleReport r = runner.run();
  if (g.json) {
    fmt::print("{}\n", report_json(r, lines.simulated()));
  } else {
    fmt::print("{}", format_end(r, lines.simulated()));
  }
  std::fflush(stdout);  // the report before the exit's message on stderr
  const std::optional<Duration> limit =
      a.max_cycle_time > Duration{} ? std::optional<Duration>(a.max_cycle_time) : std::nullopt;
  if (!a.junit.empty()) {
    std::ofstream out(a.junit);
    out << junit_xml(c.name, r, limit);
    if (!out.flush()) throw CommandFailed(kFailure, fmt::format("cannot write {}", a.junit));
  }
  if (g_interrupted.load()) return {kInterrupted, "cycle stopped (Ctrl-C): every axis was stopped"};
  if (!r.completed) return {kFailure, "cycle not completed: " + r.ended};
  if (limit && r.cycle_time > *limit) {
    return {kFailure, fmt::format("the cycle took {:.3f} s, over --max-cycle-time {:.3f} s",
                                  to_seconds(r.cycle_time), to_seconds(*limit))};
  }
  return {kSuccess, {}};
}

// Reads the whole file, or says which file and why (exit 2).
std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw cycle::CycleError(path, {}, "file", "cannot read the file");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Replaces the file by `text` whole (a temporary beside it, renamed over it):
// a crash or a full disk never leaves half a file. Its permissions are kept.
void replace_file(const std::string& path, const std::string& text) {
  namespace fs = std::filesystem;
  const fs::path tmp = fs::path(path).concat(".lec-teach.tmp");
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    if (!out.flush()) {
      std::error_code ec;
      fs::remove(tmp, ec);
      throw CommandFailed(
          kFailure, fmt::format("cannot write {}: nothing changed in {}", tmp.string(), path));
    }
  }
  std::error_code ec;
  fs::permissions(tmp, fs::status(path).permissions(), fs::perm_options::replace, ec);
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw CommandFailed(kFailure, fmt::format("cannot replace {}: {}", path, ec.message()));
  }
}

// `lec cycle teach FILE AXIS.POINT`: the axis's position (or --at) into the file.
void teach(const GlobalOptions& g, const CycleArgs& a) {
  const std::string text = read_text(a.file);
  int32_t position = 0;
  std::string where;
  if (!a.at.empty()) {
    const auto v = lec::parse_mm(a.at);
    if (!v) throw UsageError(fmt::format("--at {}: {}", a.at, v.error()));
    position = static_cast<int32_t>(*v);
    where = "--at";
  } else {
    const std::string axis = cycle::teach_axis(text, a.file, a.target);  // before any port
    const cycle::Cycle c = cycle::parse_cycle(text, a.file);
    const std::string port = cycle_port(g);
    if (port == "sim")
      throw UsageError(
          "teach reads where the axis stands: give its line (--port /dev/ttyUSB0, "
          "tcp://...) or the value (--at MM); the twin of --port sim has just "
          "been switched on");
    CycleLines lines(c, g, port);
    position = lines.clients().at(axis)->read_state().position_001mm;
    where = fmt::format("{} on {}", axis, lines.describe());
  }
  const cycle::TaughtPoint t = cycle::teach_point(text, a.file, a.target, position);
  replace_file(a.file, t.text);
  if (g.json) {
    nlohmann::json j{{"file", a.file},   {"axis", t.axis},
                     {"point", t.point}, {"position_mm", t.position_001mm / 100.0},
                     {"line", t.line},   {"added", !t.was_001mm.has_value()},
                     {"from", where}};
    if (t.was_001mm) j["was_mm"] = *t.was_001mm / 100.0;
    fmt::print("{}\n", j.dump());
    return;
  }
  fmt::print("{}:{}: {}.{} = {} mm ({}; {})\n", a.file, t.line, t.axis, t.point,
             lec::format_mm(t.position_001mm), where,
             t.was_001mm ? "was " + lec::format_mm(*t.was_001mm) + " mm" : std::string("added"));
}

void add_teach(CLI::App* cmd, const GlobalOptions& globals, const std::shared_ptr<CycleArgs>& a) {
  cmd->add_option("file", a->file, "The cycle file (YAML); kept as written but for the point")
      ->required();
  cmd->add_option("point", a->target, "AXIS.POINT (added when new), or a POINT only one axis has")
      ->required();
  cmd->add_option("--at", a->at,
                  "Write this position (mm) instead of reading where the axis stands");
  cmd->callback([&globals, a] { teach(globals, *a); });
}

}  // namespace

void add_cycle_commands(CLI::App& app, const GlobalOptions& globals) {
  auto* cycle = app.add_subcommand(
      "cycle",
      "Machine cycles of several axes from a YAML file (docs/cycles.md): check, run, teach");
  cycle->require_subcommand(1);
  auto a = std::make_shared<CycleArgs>();

  auto* chk = cycle->add_subcommand("check", "Check a cycle file; nothing is opened or moved");
  chk->add_option("file", a->file, "The cycle file (YAML)")->required();
  chk->callback([&globals, a] { check(globals, *a); });

  auto* run_cmd = cycle->add_subcommand(
      "run",
      "Run a cycle: --port sim runs it on the twin in simulated time, a serial port or "
      "tcp:// on the line in real time");
  run_cmd->add_option("file", a->file, "The cycle file (YAML)")->required();
  run_cmd->add_option("--profile", a->profile,
                      "--port sim: the twin's field profile (YAML, e.g. from lec sim --calibrate)");
  run_cmd->add_option("--junit", a->junit, "Write the cycle's assertions as JUnit XML to FILE");
  run_cmd->add_flag("--prepare", a->prepare,
                    "Serial mode, servo on and return to origin for every axis first (always "
                    "done with --port sim)");
  add_duration_option(run_cmd, "--max-cycle-time", a->max_cycle_time,
                      "Fail (exit 1, and in --junit) when the cycle takes longer",
                      {std::chrono::milliseconds(1), std::chrono::hours(24), {}});
  run_cmd->callback([&globals, a] {
    const auto [code, message] = run(globals, *a);
    if (code != kSuccess) throw CommandFailed(code, message);
  });

  // Teach-in: `lec cycle teach` and its short name `lec teach`.
  const char* teach_help =
      "Teach-in: write where an axis stands (read from --port) into a cycle file's point, "
      "keeping the file's comments and layout";
  add_teach(cycle->add_subcommand("teach", teach_help), globals, a);
  add_teach(app.add_subcommand("teach", teach_help), globals, std::make_shared<CycleArgs>());
}

}  // namespace lec6::cli
