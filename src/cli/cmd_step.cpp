// `lec step list/get/set/backup/restore/diff`: the controller's program (the
// 64 step-data records, D0400–D07FF) in the user's units, and kept in files.
//
// The step data live in EEPROM (≈100 000 writes per step), so every command
// that writes reads first and writes only the steps, and of each only the
// registers, that differ; each write is read back (--no-verify skips that);
// the output ends with a wear line: "3 steps written, 61 unchanged".
//
// Exit codes beyond the usual ones (see `lec --help`):
//   step diff      0 equal, 1 different (like diff(1)), 2 bad file, 3/4 line/controller
//   step restore   1 a read-back differed from what was written
//   step set/restore  2 with nothing sent for any bad argument or file row

#include <unistd.h>

#include <fmt/ranges.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <memory>

#include "cli/app.hpp"
#include "cli/step_views.hpp"
#include "lec6/client/step_sync.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/lec/step_assign.hpp"
#include "lec6/lec/step_table.hpp"
#include "lec6/lec/units.hpp"
#include "lec6/transport/step_table_file.hpp"

namespace lec6::cli {
namespace {

using lec::StepData;
using lec::StepField;

constexpr unsigned kSteps = lec::StepTable::kSteps;

// ---- reports -------------------------------------------------------------------

// Throws CommandFailed with the exit code of the failure, after the report was printed.
[[noreturn]] void throw_failure(const client::RestoreReport& r) {
  const auto failed = r.steps_with(client::StepOutcome::Failed);
  const std::string where =
      failed.empty() ? std::string() : fmt::format("step {}: ", failed.front());
  std::string why;
  for (const auto& s : r.steps) {
    if (s.outcome == client::StepOutcome::Failed) why = s.error;
  }
  switch (r.failure) {
    case client::FailureKind::Transport:
      throw CommandFailed(kTransport, where + why);
    case client::FailureKind::Controller:
      throw CommandFailed(kException, where + why);
    case client::FailureKind::Refused:
      throw CommandFailed(kUsage, where + why);
    case client::FailureKind::Verify:
      throw CommandFailed(kFailure, where + why);
    case client::FailureKind::Cancelled:
      throw CommandFailed(kInterrupted,
                          "interrupted: the steps not yet written were left as they were");
    case client::FailureKind::None:
      break;
  }
  throw CommandFailed(kFailure, "failed");
}

std::string port_text(const Session& s) {
  if (!s.options().port.empty()) return s.options().port;
  if (const char* env = std::getenv("LEC_PORT"); env && *env) return env;
  return "?";
}

lec::StepTable load_table(const std::string& file) {
  auto table = transport::read_table_file(file);
  if (!table) {
    const auto& errors = table.error();
    throw UsageError(fmt::format("{}: {}; nothing was sent to the controller:{}", file,
                                 count_text(errors.size(), "error", "errors"),
                                 errors_text(errors)));
  }
  return std::move(*table);
}

// ---- list / get --------------------------------------------------------------------

void run_list(Session& s, bool all) {
  auto& c = s.client();
  const auto steps = c.read_all_steps();
  std::vector<unsigned> shown;
  for (unsigned n = 0; n < kSteps; ++n) {
    if (all || !steps[n].is_blank()) shown.push_back(n);
  }
  const std::size_t in_use = static_cast<std::size_t>(
      std::count_if(steps.begin(), steps.end(), [](const StepData& d) { return !d.is_blank(); }));
  if (s.json()) {
    nlohmann::json j = nlohmann::json::array();
    for (unsigned n : shown) j.push_back(step_json(n, steps[n]));
    print_json(j);
    return;
  }
  if (shown.empty()) {
    fmt::print("no steps in use: all 64 are blank (--all lists them)\n");
    return;
  }
  print_step_table(steps, shown);
  fmt::print("{} of 64 steps in use{}\n", in_use, all ? "" : " (--all lists the blank ones too)");
}

void run_get(Session& s, unsigned n) {
  const StepData d = s.client().read_step(n);
  if (s.json()) {
    auto j = step_json(n, d);
    j["blank"] = d.is_blank();
    print_json(j);
    return;
  }
  print_step(n, d);
}

// ---- set -----------------------------------------------------------------------

struct SetArgs {
  unsigned step = 0;
  std::vector<std::string> assignments;
  int from = -1;
  bool verify = true;
};

void run_set(Session& s, const SetArgs& a) {
  // Names and values first: a typo never opens the port.
  if (auto parsed = lec::parse_assignments(a.assignments); !parsed) {
    throw UsageError(
        fmt::format("step {}: nothing was sent:{}", a.step, errors_text(parsed.error())));
  }
  if (a.assignments.empty() && a.from < 0) {
    throw UsageError(
        fmt::format("step set {}: nothing to set: give field=value ... (e.g. speed=500 "
                    "position=150.00) or --from M",
                    a.step));
  }
  auto& c = s.client();
  const StepData current = c.read_step(a.step);
  std::optional<lec::CopySource> from;
  if (a.from >= 0)
    from =
        lec::CopySource{static_cast<unsigned>(a.from), c.read_step(static_cast<unsigned>(a.from))};
  auto result = lec::assign_step(a.step, current, a.assignments, from);
  if (!result) {
    throw UsageError(
        fmt::format("step {}: nothing was written:{}", a.step, errors_text(result.error())));
  }
  // What the user did not give: the defaults a blank step took, and warnings
  // (a moving force of 0 %), on stderr so that --json stays one document.
  if (!result->defaulted.empty()) {
    std::vector<std::string> filled;
    for (const auto f : result->defaulted)
      filled.push_back(fmt::format("{}={}", lec::field_info(f).name,
                                   lec::format_field(f, lec::get_field(result->step, f))));
    fmt::print(stderr, "lec: step {} was blank: the defaults filled {}\n", a.step,
               fmt::join(filled, " "));
  }
  for (const auto& w : result->warnings) fmt::print(stderr, "lec: warning: {}\n", w);
  const auto plan = client::plan_step(a.step, current, result->step);
  client::ApplyOptions o;
  o.verify = a.verify;
  const auto report = client::apply_restore(c, plan, o);
  const auto& r = report.steps.front();
  const std::size_t written = report.count(client::StepOutcome::Written);
  if (s.json()) {
    auto j = change_json(r.change);
    j["outcome"] = client::outcome_name(r.outcome);
    j["verified"] = report.verified && r.outcome == client::StepOutcome::Written;
    j["steps_written"] = written;
    j["step_data"] =
        step_json(a.step, r.outcome == client::StepOutcome::Failed ? current : result->step);
    if (!r.error.empty()) j["error"] = r.error;
    print_json(j);
  } else if (r.outcome == client::StepOutcome::Unchanged) {
    fmt::print("step {}: unchanged (0 steps written)\n", a.step);
  } else if (r.outcome == client::StepOutcome::Written) {
    fmt::print("step {}: {} written{} [{}] (1 step written)\n", a.step, change_text(r.change),
               report.verified ? " and verified" : "", register_text(a.step, *r.change.registers));
  } else {
    fmt::print("step {}: FAILED: {} (0 steps written)\n", a.step, r.error);
  }
  if (!report.ok()) throw_failure(report);
}

// ---- backup ----------------------------------------------------------------------

void run_backup(Session& s, const std::string& file) {
  const lec::StepTable table = client::backup_steps(s.client());
  if (auto w = transport::write_table_file(file, table); !w)
    throw CommandFailed(kFailure, w.error());
  std::vector<unsigned> in_use;
  std::vector<std::string> invalid;
  for (unsigned n = 0; n < kSteps; ++n) {
    if (table.steps[n].is_blank()) continue;
    in_use.push_back(n);
    for (auto& m : lec::validation_messages(table.steps[n], n)) invalid.push_back(std::move(m));
  }
  if (s.json()) {
    print_json({{"file", file},
                {"steps", kSteps},
                {"in_use", in_use},
                {"equipment_name", table.equipment_name},
                {"controller_id", table.controller_id},
                {"invalid", invalid}});
  } else {
    fmt::print("64 steps ({} in use: {}) of controller {}{} saved to {}\n", in_use.size(),
               client::format_step_list(in_use), table.controller_id,
               table.equipment_name.empty() ? "" : fmt::format(" '{}'", table.equipment_name),
               file);
  }
  for (const auto& m : invalid) {
    fmt::print(
        stderr,
        "lec: warning: {} (saved as it is; restore refuses the file until that row is fixed)\n", m);
  }
}

// ---- restore ---------------------------------------------------------------------

struct RestoreArgs {
  std::string file;
  bool dry_run = false;
  bool verify = true;
};

void run_restore(Session& s, const RestoreArgs& a) {
  const lec::StepTable table = load_table(a.file);  // every row checked before the port is opened
  auto& c = s.client();
  const auto plan = [&] {
    try {
      return client::plan_restore(c, table);
    } catch (const std::exception&) {
      fmt::print(stderr, "lec: reading the controller's steps failed: nothing was written\n");
      throw;
    }
  }();
  const bool text = !s.json();
  if (text) {
    fmt::print("restore {} ({}) to controller {} on {}{}\n", a.file,
               count_text(plan.steps.size(), "step", "steps"), c.options().id, s.port_description(),
               a.dry_run ? ": dry run, nothing is written" : "");
    for (const auto& n : plan.notes) fmt::print("note: {}\n", n);
  }
  client::ApplyOptions o;
  o.verify = a.verify;
  o.dry_run = a.dry_run;
  o.cancel = [] { return g_interrupted.load(); };
  if (text)
    o.on_step = [](const client::StepResult& r) {
      print_step_result(r);
      std::fflush(stdout);
    };
  const auto report = client::apply_restore(c, plan, o);
  if (s.json()) {
    auto j = report_json(report);
    j["file"] = a.file;
    print_json(j);
  } else {
    if (report.verified && report.count(client::StepOutcome::Written) > 0) {
      fmt::print("every written step was read back and matches\n");
    }
    print_report_tail(report);
  }
  if (!report.ok()) throw_failure(report);
}

// ---- diff ------------------------------------------------------------------------

struct DiffArgs {
  std::string file;
  std::string with;
  int with_id = 0;
};

void finish_diff(Session& s, const client::StepDiff& d, std::string_view a, std::string_view b) {
  if (s.json()) {
    print_json(diff_json(d, a, b));
  } else {
    for (const auto& n : d.notes) fmt::print("note: {}\n", n);
    fmt::print("{}", lec::format_diff_side_by_side(d.fields, a, b));
  }
  if (!d.equal()) {
    throw CommandFailed(
        kFailure,
        fmt::format("{} differ{} in {}", count_text(d.fields.size(), "field", "fields"),
                    d.fields.size() == 1 ? "s" : "", count_text(d.steps(), "step", "steps")));
  }
}

void run_diff(Session& s, const DiffArgs& a) {
  const bool other = !a.with.empty() || a.with_id > 0;
  if (a.file.empty() == !other) {
    throw UsageError(
        "step diff: give a FILE, or --with PORT / --with-id ID for a second controller (not both)");
  }
  if (!a.file.empty()) {
    const lec::StepTable table = load_table(a.file);
    auto& c = s.client();
    const auto d = client::diff_controller(c, table);
    finish_diff(s, d, fmt::format("controller {}", c.options().id),
                std::filesystem::path(a.file).filename().string());
    return;
  }
  auto& c = s.client();
  const std::string label_a = fmt::format("{} id {}", port_text(s), c.options().id);
  const lec::StepTable ta = client::backup_steps(c);
  lec::StepTable tb;
  std::string label_b;
  if (!a.with.empty()) {
    GlobalOptions o = s.options();  // outlives `second`, which keeps a reference
    o.port = a.with;
    if (a.with_id > 0) o.id = a.with_id;
    Session second(o);
    tb = client::backup_steps(second.client());
    label_b = fmt::format("{} id {}", a.with, o.id);
  } else {
    // A second controller on the same line.
    const uint8_t first = c.options().id;
    c.set_id(static_cast<uint8_t>(a.with_id));
    try {
      tb = client::backup_steps(c);
    } catch (...) {
      c.set_id(first);
      throw;
    }
    c.set_id(first);
    label_b = fmt::format("{} id {}", port_text(s), a.with_id);
  }
  finish_diff(s, client::diff_backups(ta, tb), label_a, label_b);
}

}  // namespace

void add_step_commands(CLI::App& app, Session& session) {
  auto* step =
      app.add_subcommand("step", "The 64 step-data records: list, get, set, backup, restore, diff");
  step->require_subcommand(1);
  step->footer(
      "Fields (name=value; the manual's long names work too, any case): mode (abs|inc), speed "
      "(mm/s), position "
      "(mm), accel, decel (mm/s2), push, trigger (%), push-speed (mm/s), moving-force (%), area1, "
      "area2, "
      "in-position (mm). Lengths take up to two decimals.\n"
      "Steps live in EEPROM (about 100 000 writes each): set and restore write only what differs, "
      "read it back, "
      "and end with a count such as '3 steps written, 61 unchanged'.");

  auto all = std::make_shared<bool>(false);
  auto* list =
      step->add_subcommand("list", "Table of the steps in use (differing from a blank record)");
  list->add_flag("--all,-a", *all, "Show all 64 steps, blank ones too");
  list->callback([&session, all] { run_list(session, *all); });

  auto get_step = std::make_shared<unsigned>(0);
  auto* get = step->add_subcommand("get", "One step, every field with its unit");
  get->add_option("N", *get_step, "Step number 0-63")
      ->required()
      ->check(CLI::Range(0u, kSteps - 1));
  get->callback([&session, get_step] { run_get(session, *get_step); });

  auto set_args = std::make_shared<SetArgs>();
  auto* set = step->add_subcommand(
      "set", "Change fields of a step: lec step set 3 position=150.00 speed=500");
  set->add_option("N", set_args->step, "Step number 0-63")
      ->required()
      ->check(CLI::Range(0u, kSteps - 1));
  set->add_option("FIELD=VALUE", set_args->assignments,
                  "Fields to set, e.g. mode=abs speed=500 position=150.00");
  set->add_option("--from", set_args->from,
                  "Start from a copy of step M (e.g. to fill a blank step)")
      ->check(CLI::Range(0, static_cast<int>(kSteps) - 1));
  set->add_flag("--verify,!--no-verify", set_args->verify,
                "Read the step back after writing (default: on)");
  set->footer(
      "Refused before anything is sent: unknown fields, values out of range, a step left invalid "
      "(a blank step "
      "needs mode, speed, accel, decel and push-speed, or --from M; in-position defaults to 0).");
  set->callback([&session, set_args] { run_set(session, *set_args); });

  auto backup_file = std::make_shared<std::string>();
  auto* backup =
      step->add_subcommand("backup", "Save all 64 steps, the equipment name and ID to FILE");
  backup
      ->add_option("FILE", *backup_file, "CSV file (one row per step, header with units), or .json")
      ->required();
  backup->callback([&session, backup_file] { run_backup(session, *backup_file); });

  auto restore_args = std::make_shared<RestoreArgs>();
  auto* restore =
      step->add_subcommand("restore", "Write the steps of FILE that differ from the controller");
  restore
      ->add_option("FILE", restore_args->file, "CSV or .json file, as written by `lec step backup`")
      ->required()
      ->check(CLI::ExistingFile);
  restore->add_flag("--dry-run,-n", restore_args->dry_run,
                    "Show what would be written; write nothing");
  restore->add_flag("--verify,!--no-verify", restore_args->verify,
                    "Read each written step back (default: on)");
  restore->footer(
      "The whole file is checked first; any bad row (reported with its line) means nothing is "
      "sent. Then only "
      "the steps that differ are written, one transaction each, only the registers that differ. A "
      "restore that "
      "stopped (exit 3/4; exit 1 when a read-back differed) can be run again: it finishes what is "
      "left. The "
      "equipment name is read-only and is never written.");
  restore->callback([&session, restore_args] { run_restore(session, *restore_args); });

  auto diff_args = std::make_shared<DiffArgs>();
  auto* diff = step->add_subcommand(
      "diff", "Fields that differ between the controller and FILE (or a 2nd controller)");
  diff->add_option("FILE", diff_args->file, "CSV or .json file")->check(CLI::ExistingFile);
  diff->add_option("--with", diff_args->with, "Compare with the controller on this second port");
  diff->add_option("--with-id", diff_args->with_id, "ID of the second controller (default: --id)")
      ->check(CLI::Range(1, 255));
  diff->footer(
      "Writes nothing. Exit 0 when equal, 1 when they differ (like diff(1)), 2 for a bad file. A "
      "file compares "
      "only the steps it lists.");
  diff->callback([&session, diff_args] { run_diff(session, *diff_args); });
}

}  // namespace lec6::cli
