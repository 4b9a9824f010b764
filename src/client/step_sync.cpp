// Backup, restore and diff of the step data: see include/lec6/client/step_sync.hpp.

#include "lec6/client/step_sync.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <iterator>
#include <set>

#include "lec6/client/errors.hpp"
#include "lec6/client/link.hpp"
#include "lec6/lec/memory_map.hpp"

namespace lec6::client {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && s.front() == ' ') s.remove_prefix(1);
  while (!s.empty() && s.back() == ' ') s.remove_suffix(1);
  return s;
}

std::vector<lec::StepField> differing_fields(const lec::StepData& a, const lec::StepData& b) {
  std::vector<lec::StepField> out;
  for (const auto& i : lec::step_fields()) {
    if (lec::get_field(a, i.field) != lec::get_field(b, i.field)) out.push_back(i.field);
  }
  return out;
}

std::string plural(std::size_t n, std::string_view one, std::string_view many) {
  return fmt::format("{} {}", n, n == 1 ? one : many);
}

// Notes about what a table says of its controller that a restore does not change.
void identity_notes(std::string_view controller_name, uint8_t controller_id,
                    const lec::StepTable& table, std::vector<std::string>& notes) {
  const std::string_view file_name = trim(table.equipment_name);
  const std::string_view name = trim(controller_name);
  if (!file_name.empty() && !name.empty() && file_name != name) {
    notes.push_back(
        fmt::format("the file was saved from equipment '{}', this controller is '{}' (the name is "
                    "read-only: not "
                    "restored)",
                    file_name, name));
  }
  if (table.controller_id != 0 && controller_id != 0 && table.controller_id != controller_id) {
    notes.push_back(
        fmt::format("the file was saved from controller ID {}, this is controller ID {}",
                    table.controller_id, controller_id));
  }
}

std::string describe_readback(const lec::StepData& wrote, const lec::StepData& read) {
  std::string out;
  for (lec::StepField f : differing_fields(wrote, read)) {
    const auto& i = lec::field_info(f);
    if (!out.empty()) out += ", ";
    out +=
        fmt::format("{} reads {} (wrote {})", i.name, lec::format_field(f, lec::get_field(read, f)),
                    lec::format_field(f, lec::get_field(wrote, f)));
  }
  return out;
}

}  // namespace

// ---- backup ------------------------------------------------------------------

lec::StepTable backup_steps(Client& c) {
  lec::StepTable t;
  const auto steps = c.read_all_steps();
  std::copy(steps.begin(), steps.end(), t.steps.begin());
  t.covered.set();
  t.equipment_name = std::string(trim(c.read_name().text));
  t.controller_id = c.options().id;
  return t;
}

// ---- restore -----------------------------------------------------------------

std::size_t RestorePlan::to_write() const noexcept {
  return static_cast<std::size_t>(
      std::count_if(steps.begin(), steps.end(), [](const StepChange& s) { return !s.equal(); }));
}

std::size_t RestorePlan::unchanged() const noexcept {
  return steps.size() - to_write();
}

std::vector<unsigned> RestorePlan::steps_to_write() const {
  std::vector<unsigned> out;
  for (const auto& s : steps) {
    if (!s.equal()) out.push_back(s.step);
  }
  return out;
}

RestorePlan plan_restore(const StepRecords& have, const lec::StepTable& want,
                         std::string_view controller_name, uint8_t controller_id) {
  RestorePlan plan;
  for (unsigned n : want.covered_steps()) {
    StepChange s;
    s.step = n;
    s.have = have[n];
    s.want = want.steps[n];
    s.registers = lec::registers_that_differ(s.have, s.want);
    s.fields = differing_fields(s.have, s.want);
    plan.steps.push_back(std::move(s));
  }
  identity_notes(controller_name, controller_id, want, plan.notes);
  return plan;
}

RestorePlan plan_restore(Client& c, const lec::StepTable& want) {
  const auto have = c.read_all_steps();
  const auto name = c.read_name();
  return plan_restore(have, want, name.text, c.options().id);
}

RestorePlan plan_step(unsigned step, const lec::StepData& have, const lec::StepData& want) {
  StepRecords records{};
  records[step] = have;
  lec::StepTable table;
  table.covered.reset();
  table.covered.set(step);
  table.steps[step] = want;
  return plan_restore(records, table);
}

std::string_view outcome_name(StepOutcome o) noexcept {
  switch (o) {
    case StepOutcome::Unchanged:
      return "unchanged";
    case StepOutcome::Written:
      return "written";
    case StepOutcome::Failed:
      return "failed";
    case StepOutcome::NotAttempted:
      return "not attempted";
    case StepOutcome::Planned:
      return "to write";
  }
  return "?";
}

std::size_t RestoreReport::count(StepOutcome o) const noexcept {
  return static_cast<std::size_t>(std::count_if(
      steps.begin(), steps.end(), [o](const StepResult& r) { return r.outcome == o; }));
}

std::vector<unsigned> RestoreReport::steps_with(StepOutcome o) const {
  std::vector<unsigned> out;
  for (const auto& r : steps) {
    if (r.outcome == o) out.push_back(r.change.step);
  }
  return out;
}

std::string RestoreReport::summary() const {
  std::string out;
  if (dry_run) {
    out = fmt::format("{} to write", plural(count(StepOutcome::Planned), "step", "steps"));
  } else {
    out = fmt::format("{} written", plural(count(StepOutcome::Written), "step", "steps"));
    if (const auto f = count(StepOutcome::Failed)) out += fmt::format(", {} failed", f);
    if (const auto n = count(StepOutcome::NotAttempted))
      out += fmt::format(", {} not attempted", n);
  }
  out += fmt::format(", {} unchanged", count(StepOutcome::Unchanged));
  if (steps.size() < lec::StepTable::kSteps) {
    out += fmt::format(" ({} not in the file)",
                       plural(lec::StepTable::kSteps - steps.size(), "step", "steps"));
  }
  return out;
}

RestoreReport apply_restore(Client& c, const RestorePlan& plan, const ApplyOptions& options) {
  RestoreReport report;
  report.notes = plan.notes;
  report.dry_run = options.dry_run;
  report.verified = options.verify && !options.dry_run;
  for (const StepChange& change : plan.steps) {
    StepResult r;
    r.change = change;
    if (change.equal()) {
      r.outcome = StepOutcome::Unchanged;
    } else if (options.dry_run) {
      r.outcome = StepOutcome::Planned;
    } else if (report.failure != FailureKind::None) {
      r.outcome = StepOutcome::NotAttempted;
    } else if (options.cancel && options.cancel()) {
      report.failure = FailureKind::Cancelled;
      r.outcome = StepOutcome::NotAttempted;
    } else {
      auto fail = [&](FailureKind kind, std::string why, bool maybe_written) {
        report.failure = kind;
        report.exception = std::current_exception();
        r.outcome = StepOutcome::Failed;
        r.error = std::move(why);
        r.maybe_written = maybe_written;
      };
      bool sent = false;
      try {
        lec::RegisterRange range = *change.registers;
        bool confirmed = false;  // read back equal while recovering from a lost reply
        for (int attempt = 0;; ++attempt) {
          try {
            // One FC10, never resent by the client: a lost reply is settled by
            // reading the step back, not by writing EEPROM twice.
            c.write_step_registers(change.step, change.want, range.first, range.count(),
                                   Retry::Never);
            break;
          } catch (const TransportError&) {
            // The reply was lost or garbled: the write may or may not have
            // landed. Look before writing again, so that a lost reply never
            // costs a second EEPROM write.
            if (attempt >= c.options().retries) throw;
            ++r.lost_replies;
            const lec::StepData now = c.read_step(change.step);
            const auto still = lec::registers_that_differ(now, change.want);
            if (!still) {
              confirmed = true;
              break;
            }
            range = *still;
          }
        }
        sent = true;
        if (options.verify && !confirmed) {
          const lec::StepData back = c.read_step(change.step);
          if (back != change.want) {
            fail(FailureKind::Verify,
                 fmt::format("read back differs from what was written: {}",
                             describe_readback(change.want, back)),
                 true);
          }
        }
        if (r.outcome != StepOutcome::Failed) r.outcome = StepOutcome::Written;
      } catch (const Cancelled& e) {
        // Ctrl-C landed during this step's exchanges: reported like any other
        // end, with what may have been written (the rest is not attempted).
        fail(FailureKind::Cancelled,
             sent ? fmt::format("written, then interrupted before the read-back: {}", e.what())
                  : fmt::format("interrupted during the write: {}; `lec step diff` shows "
                                "what the controller holds",
                                e.what()),
             true);
      } catch (const InvalidRequest& e) {
        fail(FailureKind::Refused, e.what(), false);
      } catch (const ControllerException& e) {
        fail(FailureKind::Controller,
             sent ? fmt::format("written, but reading it back failed: {}", e.what())
                  : std::string(e.what()),
             sent || r.lost_replies > 0);
      } catch (const TransportError& e) {
        fail(FailureKind::Transport,
             sent ? fmt::format("written, but reading it back failed: {}", e.what())
                  : fmt::format("{} (the write may have reached the controller)", e.what()),
             true);
      } catch (const LinkError& e) {
        fail(FailureKind::Transport,
             sent ? fmt::format("written, but reading it back failed: {}", e.what())
                  : fmt::format("{} (the write may have reached the controller)", e.what()),
             true);
      }
    }
    report.steps.push_back(std::move(r));
    if (options.on_step) options.on_step(report.steps.back());
  }
  return report;
}

// ---- diff --------------------------------------------------------------------

std::size_t StepDiff::steps() const {
  std::set<unsigned> s;
  for (const auto& d : fields) s.insert(d.step);
  return s.size();
}

StepDiff diff_steps(const lec::StepTable& controller, const lec::StepTable& table) {
  StepDiff d;
  d.fields = lec::diff(controller, table);
  identity_notes(controller.equipment_name, controller.controller_id, table, d.notes);
  return d;
}

StepDiff diff_controller(Client& c, const lec::StepTable& table) {
  return diff_steps(backup_steps(c), table);
}

StepDiff diff_controllers(Client& a, Client& b) {
  const lec::StepTable ta = backup_steps(a);
  return diff_backups(ta, backup_steps(b));
}

StepDiff diff_backups(const lec::StepTable& ta, const lec::StepTable& tb) {
  StepDiff d;
  d.fields = lec::diff(ta, tb);
  if (trim(ta.equipment_name) != trim(tb.equipment_name)) {
    d.notes.push_back(fmt::format("equipment names differ: '{}' and '{}' (not compared as steps)",
                                  ta.equipment_name, tb.equipment_name));
  }
  return d;
}

std::string format_step_list(const std::vector<unsigned>& steps) {
  if (steps.empty()) return "none";
  std::vector<unsigned> s = steps;
  std::sort(s.begin(), s.end());
  std::string out;
  for (std::size_t i = 0; i < s.size();) {
    std::size_t j = i;
    while (j + 1 < s.size() && s[j + 1] == s[j] + 1) ++j;
    if (!out.empty()) out += ", ";
    out += j > i ? fmt::format("{}-{}", s[i], s[j]) : fmt::format("{}", s[i]);
    i = j + 1;
  }
  return out;
}

}  // namespace lec6::client
