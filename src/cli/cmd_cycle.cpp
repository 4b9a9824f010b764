// `lec cycle check FILE` and `lec cycle run FILE`: machine cycles (issue 34,
// docs/cycles.md). The file is read and checked whole before any port is
// opened; a bad file exits 2 with file:line:column: field: rule.

#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli/app.hpp"
#include "cli/cycle_html.hpp"
#include "cli/cycle_lines.hpp"
#include "cli/cycle_report.hpp"
#include "cli/duration_option.hpp"
#include "cli/file_output.hpp"
#include "cli/twin_faults.hpp"
#include "lec6/cycle/analysis.hpp"
#include "lec6/cycle/cycle_file.hpp"
#include "lec6/cycle/runner.hpp"
#include "lec6/cycle/teach.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::cli {

namespace {

struct CycleArgs {
  std::string file;
  std::string junit;
  std::string html;                 // --report FILE
  std::vector<std::string> faults;  // --fault
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
  std::vector<cycle::Fault> faults = c.faults;
  for (const auto& f : a.faults) faults.push_back(cycle::parse_fault(f, "--fault", c));
  check_outputs({{"--report", a.html}, {"--junit", a.junit}}, {a.file});
  const std::string port = cycle_port(g);
  if (!a.faults.empty() && port != "sim") {
    throw UsageError("--fault makes the twin act out a fault: it goes with --port sim");
  }
  CycleLines lines(c, g, port, a.profile);
  if (!lines.simulated() && !c.faults.empty()) {
    fmt::print(stderr,
               "lec: note: the {} fault{} of {} are for the twin (--port sim): none is injected "
               "on a line\n",
               c.faults.size(), c.faults.size() == 1 ? "" : "s", a.file);
  }
  if (lines.simulated() || a.prepare) lines.prepare(c);
  if (!g.json) {
    fmt::print("cycle '{}' on {}\n", c.name, lines.describe());
    std::fflush(stdout);
  }
  std::optional<TwinFaults> twin_faults;
  if (lines.simulated() && !faults.empty()) twin_faults.emplace(c, faults, lines);
  // (c is the Cycle the Runner runs: TwinFaults knows its steps by address.)
  cycle::RunOptions o;
  o.stop_requested = [] { return g_interrupted.load(); };
  if (twin_faults) {
    o.at_step = [&](const cycle::Step& step, const std::string& path, cycle::StepMoment m) {
      twin_faults->at_step(step, path, m);
      if (g.json) return;
      for (const auto& line : twin_faults->take_news()) fmt::print("{}\n", line);
    };
  }
  if (!g.json) {
    o.on_step = [](const cycle::StepReport& s) {
      fmt::print("{}", format_step(s));
      std::fflush(stdout);
    };
  }
  cycle::Runner runner(c, lines.clients(), o);
  const cycle::CycleReport r = runner.run();
  const cycle::CycleAnalysis analysis = cycle::analyse(r);
  const std::vector<InjectedFault> injected =
      twin_faults ? twin_faults->report() : std::vector<InjectedFault>{};
  if (g.json) {
    fmt::print("{}\n", report_json(c.name, r, analysis, lines.simulated(), injected));
  } else {
    fmt::print("{}{}", format_end(r, lines.simulated()), format_analysis(analysis));
    for (const auto& f : injected) fmt::print("  fault: {}\n", format_fault(f));
  }
  std::fflush(stdout);  // the report before the exit's message on stderr
  const std::optional<Duration> limit =
      a.max_cycle_time > Duration{} ? std::optional<Duration>(a.max_cycle_time) : std::nullopt;
  // Both reports are written, whatever became of the other; a report that
  // could not be written fails a run that completed.
  std::vector<std::string> unwritten;
  if (!a.html.empty()) {
    const CycleReportPage page{c.name, a.file, lines.describe(), lines.simulated()};
    if (auto e = write_output("--report", a.html, cycle_html(page, r, analysis)))
      unwritten.push_back(*e);
  }
  if (!a.junit.empty()) {
    if (auto e = write_output("--junit", a.junit, junit_xml(c.name, r, limit)))
      unwritten.push_back(*e);
  }
  for (const auto& e : unwritten) fmt::print(stderr, "lec: {}\n", e);
  if (g_interrupted.load()) return {kInterrupted, "cycle stopped (Ctrl-C): every axis was stopped"};
  if (!r.completed) return {kFailure, "cycle not completed: " + r.ended};
  if (limit && r.cycle_time > *limit) {
    return {kFailure, fmt::format("the cycle took {:.3f} s, over --max-cycle-time {:.3f} s",
                                  to_seconds(r.cycle_time), to_seconds(*limit))};
  }
  if (!unwritten.empty()) return {kFailure, "the cycle completed; a report was not written"};
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
  run_cmd->add_option("--report", a->html,
                      "Write an HTML report to FILE: the Gantt chart, the critical path, where "
                      "the time went (motion, line, dwells), each line's utilisation");
  run_cmd
      ->add_option("--fault", a->faults,
                   "--port sim: a fault for the twin to act out, as in the file's faults: "
                   "'{step: 6, push_miss: z}', '{step: 3, alarm: z, code: 149}', "
                   "'{step: 5, cut_off: x}' (repeatable)")
      ->allow_extra_args(false);  // one value per --fault: a FILE after it stays the file
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
