#pragma once
// The controller's program (the 64 step-data records) against a StepTable:
// backup, plan a restore, apply it, diff. Used by `lec step ...`.
//
//   auto table = lec6::client::backup_steps(client);        // 10 reads + the name
//   auto plan  = lec6::client::plan_restore(client, table);  // what differs, nothing written
//   auto rep   = lec6::client::apply_restore(client, plan);  // one FC10 per differing step
//   fmt::print("{}\n", rep.summary());                       // "3 steps written, 61 unchanged"
//
// EEPROM wear (≈100 000 writes per step, manual §3) is the constraint: a
// restore writes only the steps that differ, and of each only the smallest
// range of registers that covers every differing register, in one
// transaction. Steps that are equal are never written. A restore is
// idempotent: run again after it finished, it writes nothing; run again after
// it was interrupted, it writes only what is still missing.
//
// Failures: apply_restore stops at the first step that fails (a transport
// error, an exception reply, or a read-back that differs from what was
// written) and reports exactly which steps were written before it, which
// failed, and which were not attempted. It does not throw for those; the
// reads before any write (plan_restore, backup_steps) do throw (errors.hpp),
// and then nothing was written.
//
// Files are not this layer's: the table is text (lec/step_table.hpp) and
// `lec step backup/restore` reads and writes it with
// transport/step_table_file.hpp (read_table_file, write_table_file).
//
// Thread safety: the functions use the Client they are given, from the calling thread; one at a
// time per Client.

#include <array>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "lec6/client/client.hpp"
#include "lec6/expected.hpp"
#include "lec6/lec/step_data.hpp"
#include "lec6/lec/step_table.hpp"

namespace lec6::client {

using StepRecords = std::array<lec::StepData, lec::StepTable::kSteps>;

// ---- backup ----------------------------------------------------------------

// Every step (read_all_steps: 10 transactions), the equipment name (D000E)
// and the client's controller ID. Writes nothing.
lec::StepTable backup_steps(Client& c);

// ---- restore -----------------------------------------------------------------

// One step of a restore: what the controller holds, what the table wants.
struct StepChange {
  unsigned step = 0;
  lec::StepData have;                           // on the controller
  lec::StepData want;                           // in the table
  std::optional<lec::RegisterRange> registers;  // to write; nullopt = equal
  std::vector<lec::StepField> fields;           // fields that differ, register order

  bool equal() const noexcept { return !registers.has_value(); }
  // The step is in use on the controller and the table makes it blank.
  bool blanks() const noexcept { return want.is_blank() && !have.is_blank(); }
};

struct RestorePlan {
  std::vector<StepChange> steps;  // the steps the table covers, in step order
  // Differences that are not written, for the user: a different equipment
  // name (read-only, D000E) or controller ID than the file was saved from.
  std::vector<std::string> notes;

  std::size_t to_write() const noexcept;
  std::size_t unchanged() const noexcept;
  std::vector<unsigned> steps_to_write() const;
};

// Pure: the plan for a table against records already read. `controller_name`
// and `controller_id` feed the notes only (pass "" / 0 to skip them).
RestorePlan plan_restore(const StepRecords& have, const lec::StepTable& want,
                         std::string_view controller_name = {}, uint8_t controller_id = 0);
// Reads every step and the name (11 transactions), then plans. Writes nothing.
RestorePlan plan_restore(Client& c, const lec::StepTable& want);
// A plan for one step (what `lec step set` writes).
RestorePlan plan_step(unsigned step, const lec::StepData& have, const lec::StepData& want);

enum class StepOutcome {
  Unchanged,     // equal: not written
  Written,       // written (and, with verify, read back equal)
  Failed,        // the write or its read-back failed: see StepResult::error
  NotAttempted,  // after a failure (or cancel): not written
  Planned,       // dry run: would be written
};
std::string_view outcome_name(StepOutcome o) noexcept;  // "unchanged", "written", ...

struct StepResult {
  StepChange change;
  StepOutcome outcome = StepOutcome::Unchanged;
  std::string error;  // Failed only
  // Failed only: whether the write request may have reached the controller
  // (its reply was lost, or the read-back failed or differed). Then the
  // step's content is uncertain; a re-run compares and finishes it.
  bool maybe_written = false;
  // Replies to this step's writes that were lost and recovered by reading
  // the step back (see apply_restore).
  unsigned lost_replies = 0;
};

enum class FailureKind {
  None,
  Transport,   // TransportError / LinkError while writing or reading back
  Controller,  // an exception reply
  Verify,      // the read-back differs from what was written
  Refused,     // InvalidRequest: the client refused to send (nothing was sent)
  Cancelled,   // ApplyOptions::cancel said stop (between steps)
};

struct RestoreReport {
  std::vector<StepResult> steps;   // as in the plan
  std::vector<std::string> notes;  // from the plan
  FailureKind failure = FailureKind::None;
  std::exception_ptr exception;  // what was thrown, for Transport/Controller/Refused
  bool dry_run = false;
  bool verified = false;

  std::size_t count(StepOutcome o) const noexcept;
  std::vector<unsigned> steps_with(StepOutcome o) const;
  bool ok() const noexcept { return failure == FailureKind::None; }
  // "3 steps written, 61 unchanged"; "2 steps written, 1 failed, 4 not
  // attempted, 57 unchanged"; dry run: "3 steps to write, 61 unchanged".
  std::string summary() const;
};

struct ApplyOptions {
  bool verify = true;    // read each written step back and compare it
  bool dry_run = false;  // plan only: outcomes Planned / Unchanged, nothing sent
  // Asked before each write; true stops the restore (FailureKind::Cancelled).
  std::function<bool()> cancel;
  // Called after each step's outcome is known (for progress output).
  std::function<void(const StepResult&)> on_step;
};

// Writes the plan's differing steps in step order, one FC10 per step (the
// plan's register range), each read back when verify is on. Stops at the
// first failure; see the top of this file.
//
// A write is never resent blindly: when its reply is lost (timeout, CRC,
// framing), the step is read back first. If the write arrived, the step is
// done (and that read was its verification); if not, only the registers that
// still differ are written again, up to ClientOptions::retries times. So a
// lost reply never costs a second EEPROM write of the same data.
RestoreReport apply_restore(Client& c, const RestorePlan& plan, const ApplyOptions& options = {});

// ---- diff --------------------------------------------------------------------

struct StepDiff {
  std::vector<lec::StepFieldDiff> fields;  // a = the first side, b = the second
  std::vector<std::string> notes;          // equipment name / controller ID differ
  bool equal() const noexcept { return fields.empty(); }
  std::size_t steps() const;  // how many steps differ
};

// The controller (a) against the table (b), for the steps the table covers.
StepDiff diff_steps(const lec::StepTable& controller, const lec::StepTable& table);
// Backs up the controller, then diffs it against the table. Writes nothing.
StepDiff diff_controller(Client& c, const lec::StepTable& table);
// Two controllers' backups, every step both cover; notes a name difference.
StepDiff diff_backups(const lec::StepTable& a, const lec::StepTable& b);
// Two controllers (each backed up), every step. Writes nothing.
StepDiff diff_controllers(Client& a, Client& b);

// "0-3, 5, 9-63" for a list of step numbers ("none" when empty).
std::string format_step_list(const std::vector<unsigned>& steps);

}  // namespace lec6::client
