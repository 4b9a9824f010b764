// Backup / restore / diff of the step data against the in-process twin on a
// virtual clock. The twin's per-step write counters (eeprom().step_writes)
// show exactly which steps a restore wrote.
// Over 450 lines: backup, restore, diff and their failure cases share one fixture.

#include "lec6/client/step_sync.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include "client/sim_fixture.hpp"
#include "lec6/client/errors.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/modbus/crc.hpp"
#include "lec6/transport/file.hpp"
#include "lec6/transport/step_table_file.hpp"

namespace lec6::client {
namespace {

using lec::MovementMode;
using lec::StepData;
using lec::StepTable;
using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

// Tables in files, as `lec step backup/restore` keeps them.
using transport::read_table_file;
using transport::write_table_file;

StepData step(int32_t position_001mm, uint16_t speed = 500) {
  StepData s;
  s.movement_mode = MovementMode::Absolute;
  s.speed_mm_s = speed;
  s.position_001mm = position_001mm;
  s.acceleration_mm_s2 = 5000;
  s.deceleration_mm_s2 = 5000;
  s.pushing_speed_mm_s = 20;
  s.moving_force_pct = 100;
  s.in_position_001mm = 100;
  return s;
}

std::string data_path(std::string_view name) {
  return std::string(LEC6_TEST_DATA_DIR) + "/steps/" + std::string(name);
}

bool is_write(const modbus::Bytes& frame) {
  return frame.size() > 1 && frame[1] == 0x10;
}

std::size_t writes_sent(const std::vector<modbus::Bytes>& frames) {
  return static_cast<std::size_t>(std::count_if(frames.begin(), frames.end(), is_write));
}

// The twin with steps 0–9 in use (positions 10.00 … 100.00 mm), counters at 0.
struct StepSync : ::testing::Test {
  StepSync() {
    sim::Eeprom e = twin().eeprom();
    for (unsigned n = 0; n < 10; ++n) e.steps[n] = step(static_cast<int32_t>((n + 1) * 1000));
    twin().restore_eeprom(e);
  }
  sim::Controller& twin(uint8_t id = 1) { return *f.bus.find(id); }
  const std::array<uint32_t, 64>& counters(uint8_t id = 1) { return twin(id).eeprom().step_writes; }
  std::vector<unsigned> written_steps(uint8_t id = 1) {
    std::vector<unsigned> out;
    for (unsigned n = 0; n < 64; ++n) {
      if (counters(id)[n] != 0) out.push_back(n);
    }
    return out;
  }
  StepRecords controller_steps(uint8_t id = 1) {
    StepRecords r{};
    std::copy(twin(id).eeprom().steps.begin(), twin(id).eeprom().steps.end(), r.begin());
    return r;
  }

  testing::SimFixture f{sim::LineConfig{}, {1, 2}};
};

TEST_F(StepSync, BackupReadsEveryStepTheNameAndTheIdWithoutWriting) {
  const StepTable t = backup_steps(*f.client);
  EXPECT_TRUE(t.covered.all());
  EXPECT_EQ(t.steps[0], step(1000));
  EXPECT_EQ(t.steps[9], step(10000));
  EXPECT_TRUE(t.steps[10].is_blank());
  EXPECT_EQ(t.equipment_name, twin().eeprom().name.text);
  EXPECT_FALSE(t.equipment_name.empty());
  EXPECT_EQ(t.controller_id, 1);
  EXPECT_EQ(f.sent.size(), 11u);  // 10 reads of step data (7 steps each) + the name
  EXPECT_EQ(writes_sent(f.sent), 0u);
}

TEST_F(StepSync, RestoreWritesOnlyTheDifferingStepsAndRegisters) {
  StepTable want = backup_steps(*f.client);
  want.steps[2].speed_mm_s = 600;     // one register (offset 1)
  want.steps[7].position_001mm += 1;  // the low word of position only (offset 3)
  want.steps[20] = step(-1250, 80);   // blank on the controller: a new step
  want.steps[20].area2_001mm = 5;     // …whose last differing register is offset 13
  f.sent.clear();

  const RestorePlan plan = plan_restore(*f.client, want);
  EXPECT_EQ(writes_sent(f.sent), 0u);
  EXPECT_EQ(plan.to_write(), 3u);
  EXPECT_EQ(plan.unchanged(), 61u);
  EXPECT_THAT(plan.steps_to_write(), ElementsAre(2u, 7u, 20u));
  EXPECT_EQ(plan.steps[2].registers, (lec::RegisterRange{1, 1}));
  EXPECT_THAT(plan.steps[2].fields, ElementsAre(lec::StepField::Speed));
  EXPECT_EQ(plan.steps[7].registers, (lec::RegisterRange{3, 3}));
  EXPECT_EQ(plan.steps[20].registers, (lec::RegisterRange{0, 15}));
  EXPECT_TRUE(plan.notes.empty());

  f.sent.clear();
  const RestoreReport r = apply_restore(*f.client, plan);
  EXPECT_TRUE(r.ok());
  EXPECT_TRUE(r.verified);
  EXPECT_THAT(r.steps_with(StepOutcome::Written), ElementsAre(2u, 7u, 20u));
  EXPECT_EQ(r.count(StepOutcome::Unchanged), 61u);
  EXPECT_EQ(r.summary(), "3 steps written, 61 unchanged");

  // The twin's counters: those three steps, once each; nothing else.
  EXPECT_THAT(written_steps(), ElementsAre(2u, 7u, 20u));
  EXPECT_EQ(counters()[2], 1u);
  EXPECT_EQ(counters()[7], 1u);
  EXPECT_EQ(counters()[20], 1u);
  EXPECT_EQ(controller_steps(), want.steps);

  // One FC10 per step, of exactly the differing registers; each read back.
  std::vector<modbus::Bytes> writes;
  std::copy_if(f.sent.begin(), f.sent.end(), std::back_inserter(writes), is_write);
  ASSERT_EQ(writes.size(), 3u);
  auto start = [](const modbus::Bytes& b) { return static_cast<unsigned>(b[2] << 8 | b[3]); };
  auto count = [](const modbus::Bytes& b) { return static_cast<unsigned>(b[4] << 8 | b[5]); };
  EXPECT_EQ(start(writes[0]), lec::step_address(2) + 1u);
  EXPECT_EQ(count(writes[0]), 1u);
  EXPECT_EQ(start(writes[1]), lec::step_address(7) + 3u);
  EXPECT_EQ(count(writes[1]), 1u);
  EXPECT_EQ(start(writes[2]), lec::step_address(20) + 0u);
  EXPECT_EQ(count(writes[2]), 16u);
  EXPECT_EQ(f.sent.size(), 6u);  // three writes, three read-backs
}

TEST_F(StepSync, ASecondRestoreWritesNothing) {
  StepTable want = backup_steps(*f.client);
  want.steps[4].acceleration_mm_s2 = 1234;
  apply_restore(*f.client, plan_restore(*f.client, want));
  f.sent.clear();
  const RestoreReport again = apply_restore(*f.client, plan_restore(*f.client, want));
  EXPECT_TRUE(again.ok());
  EXPECT_EQ(again.summary(), "0 steps written, 64 unchanged");
  EXPECT_EQ(writes_sent(f.sent), 0u);
  EXPECT_THAT(written_steps(), ElementsAre(4u));
  EXPECT_EQ(counters()[4], 1u);
}

TEST_F(StepSync, BlankRowsRestoreAsBlankThroughCsv) {
  // A backup taken when steps 3 and 8 were blank, restored after they came into use.
  StepTable backup = backup_steps(*f.client);
  backup.steps[3] = StepData{};
  backup.steps[8] = StepData{};
  const std::string csv = lec::to_csv(backup);
  EXPECT_THAT(csv, HasSubstr("\n3,0,0,0.00,0,0,0,0,0,0,0.00,0.00,0.00\n"));
  const auto parsed = lec::parse_csv(csv);
  ASSERT_TRUE(parsed) << parsed.error()[0];

  const RestoreReport r = apply_restore(*f.client, plan_restore(*f.client, *parsed));
  EXPECT_TRUE(r.ok());
  EXPECT_THAT(r.steps_with(StepOutcome::Written), ElementsAre(3u, 8u));
  EXPECT_TRUE(r.steps[3].change.blanks());
  EXPECT_TRUE(twin().eeprom().steps[3].is_blank());
  EXPECT_TRUE(twin().eeprom().steps[8].is_blank());
  EXPECT_EQ(twin().eeprom().steps[4], step(5000));
}

TEST_F(StepSync, APartialFileTouchesOnlyTheStepsItLists) {
  StepTable want;
  want.covered.reset();
  want.covered.set(5);
  want.steps[5] = step(4242);  // every other step of this table is blank, but not covered
  const RestorePlan plan = plan_restore(*f.client, want);
  ASSERT_EQ(plan.steps.size(), 1u);
  const RestoreReport r = apply_restore(*f.client, plan);
  EXPECT_EQ(r.summary(), "1 step written, 0 unchanged (63 steps not in the file)");
  EXPECT_THAT(written_steps(), ElementsAre(5u));
  EXPECT_EQ(twin().eeprom().steps[0], step(1000));  // in use, not in the file: kept
}

TEST_F(StepSync, DryRunSendsNoWrite) {
  StepTable want = backup_steps(*f.client);
  want.steps[1].speed_mm_s = 42;
  const RestorePlan plan = plan_restore(*f.client, want);
  f.sent.clear();
  ApplyOptions o;
  o.dry_run = true;
  const RestoreReport r = apply_restore(*f.client, plan, o);
  EXPECT_TRUE(r.ok());
  EXPECT_THAT(r.steps_with(StepOutcome::Planned), ElementsAre(1u));
  EXPECT_EQ(r.summary(), "1 step to write, 63 unchanged");
  EXPECT_TRUE(f.sent.empty());
  EXPECT_TRUE(written_steps().empty());
}

// A link that changes what a write to one step carries on its way (the CRC
// made good again), as a controller that did not keep what it was sent would.
class AlteringLink final : public Link {
 public:
  AlteringLink(Link& inner, unsigned step) : inner_(inner), step_(step) {}
  void write(std::span<const uint8_t> bytes) override {
    modbus::Bytes b(bytes.begin(), bytes.end());
    const unsigned start = b.size() > 8 ? static_cast<unsigned>(b[2] << 8 | b[3]) : 0;
    if (is_write(b) && start / lec::kStepStride == lec::step_address(step_) / lec::kStepStride) {
      b[b.size() - 3] ^= 0x01;  // low byte of the last register written
      const uint16_t crc = modbus::crc16(std::span(b).first(b.size() - 2));
      b[b.size() - 2] = static_cast<uint8_t>(crc & 0xFF);
      b[b.size() - 1] = static_cast<uint8_t>(crc >> 8);
    }
    inner_.write(b);
  }
  std::size_t read_some(std::span<uint8_t> buffer, TimePoint deadline) override {
    return inner_.read_some(buffer, deadline);
  }
  void discard_input() override { inner_.discard_input(); }
  const Clock& clock() const override { return inner_.clock(); }
  uint32_t baud() const override { return inner_.baud(); }
  std::string describe() const override { return inner_.describe(); }

 private:
  Link& inner_;
  unsigned step_;
};

TEST_F(StepSync, VerifyCatchesAStepThatReadsBackDifferentlyAndStops) {
  StepTable want = backup_steps(*f.client);
  for (unsigned n : {1u, 4u, 6u}) want.steps[n].speed_mm_s = 777;  // one register each, offset 1
  AlteringLink altering(*f.link, 4);
  Client c(altering, f.options());
  const RestoreReport r = apply_restore(c, plan_restore(c, want));
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.failure, FailureKind::Verify);
  EXPECT_THAT(r.steps_with(StepOutcome::Written), ElementsAre(1u));
  EXPECT_THAT(r.steps_with(StepOutcome::Failed), ElementsAre(4u));
  EXPECT_THAT(r.steps_with(StepOutcome::NotAttempted), ElementsAre(6u));
  EXPECT_THAT(r.steps[4].error,
              AllOf(HasSubstr("read back differs"), HasSubstr("speed reads 776 (wrote 777)")));
  EXPECT_TRUE(r.steps[4].maybe_written);
  EXPECT_EQ(r.summary(), "1 step written, 1 failed, 1 not attempted, 61 unchanged");
  EXPECT_THAT(written_steps(), ElementsAre(1u, 4u));

  // Without verify the same fault goes unnoticed: that is what verify is for.
  AlteringLink again(*f.link, 6);
  Client unverified(again, f.options());
  ApplyOptions o;
  o.verify = false;
  const RestoreReport blind = apply_restore(unverified, plan_restore(unverified, want), o);
  EXPECT_TRUE(blind.ok());
  EXPECT_FALSE(blind.verified);
  EXPECT_THAT(blind.steps_with(StepOutcome::Written), ElementsAre(4u, 6u));
  EXPECT_NE(twin().eeprom().steps[6], want.steps[6]);

  // A re-run over a good line finishes the job: only step 6 still differs.
  const RestoreReport fixed = apply_restore(*f.client, plan_restore(*f.client, want));
  EXPECT_TRUE(fixed.ok());
  EXPECT_THAT(fixed.steps_with(StepOutcome::Written), ElementsAre(6u));
  EXPECT_EQ(controller_steps(), want.steps);
}

TEST_F(StepSync, VerifyCatchesAnotherMasterChangingTheStepBetweenPlanAndWrite) {
  StepTable want = backup_steps(*f.client);
  want.steps[2].speed_mm_s = 999;
  const RestorePlan plan = plan_restore(*f.client, want);
  sim::Eeprom e = twin().eeprom();
  e.steps[2].in_position_001mm = 55;  // outside the range the plan writes
  twin().restore_eeprom(e);
  const RestoreReport r = apply_restore(*f.client, plan);
  EXPECT_EQ(r.failure, FailureKind::Verify);
  EXPECT_THAT(r.steps[2].error, HasSubstr("in-position reads 0.55 (wrote 1.00)"));
  // Re-planning sees it and writes the rest of the step.
  EXPECT_TRUE(apply_restore(*f.client, plan_restore(*f.client, want)).ok());
  EXPECT_EQ(twin().eeprom().steps[2], want.steps[2]);
}

TEST_F(StepSync, AnInterruptedRestoreIsSafeToRunAgain) {
  StepTable want = backup_steps(*f.client);
  const std::vector<unsigned> changed{0, 3, 9, 11, 40};
  for (unsigned n : changed) want.steps[n] = step(static_cast<int32_t>(n * 777 + 1), 123);

  // The client's usual retries (2): a lost write reply is looked into by
  // reading, never by writing again, so each step reaches the twin once.
  ASSERT_EQ(f.client->options().retries, 2);
  const RestorePlan plan = plan_restore(*f.client, want);
  int writes = 0;
  f.on_trace = [&](const TraceEvent& e) {
    if (e.outgoing && e.bytes.size() > 1 && e.bytes[1] == 0x10 && ++writes == 3) {
      sim::FaultConfig drop;
      drop.drop = 1.0;
      f.bus.set_faults(drop);  // the third write arrives; its reply and every later one is lost
    }
  };
  f.sent.clear();
  const RestoreReport r = apply_restore(*f.client, plan);
  EXPECT_EQ(r.failure, FailureKind::Transport);
  EXPECT_THAT(r.steps_with(StepOutcome::Written), ElementsAre(0u, 3u));
  EXPECT_THAT(r.steps_with(StepOutcome::Failed), ElementsAre(9u));
  EXPECT_THAT(r.steps_with(StepOutcome::NotAttempted), ElementsAre(11u, 40u));
  EXPECT_TRUE(r.steps[9].maybe_written);
  EXPECT_EQ(r.steps[9].lost_replies, 1u);
  EXPECT_THAT(r.steps[9].error, HasSubstr("may have reached the controller"));
  ASSERT_TRUE(r.exception);
  EXPECT_THROW(std::rethrow_exception(r.exception), TransportError);
  EXPECT_EQ(r.summary(), "2 steps written, 1 failed, 2 not attempted, 59 unchanged");
  EXPECT_EQ(writes, 3);  // stopped at the failure, the write not repeated
  EXPECT_EQ(counters()[9], 1u);

  // The line is good again: run the same restore.
  f.on_trace = nullptr;
  f.bus.set_faults({});
  const RestoreReport again = apply_restore(*f.client, plan_restore(*f.client, want));
  EXPECT_TRUE(again.ok());
  // Step 9 did reach the twin before its reply was lost: now equal, not rewritten.
  EXPECT_THAT(again.steps_with(StepOutcome::Written), ElementsAre(11u, 40u));
  EXPECT_EQ(controller_steps(), want.steps);
  EXPECT_EQ(written_steps(), changed);
  for (unsigned n : changed) EXPECT_EQ(counters()[n], 1u) << "step " << n;
  EXPECT_EQ(apply_restore(*f.client, plan_restore(*f.client, want)).summary(),
            "0 steps written, 64 unchanged");
}

TEST_F(StepSync, ALostWriteReplyIsSettledByReadingBackNotByWritingAgain) {
  StepTable want = backup_steps(*f.client);
  for (unsigned n : {2u, 5u, 8u}) want.steps[n].deceleration_mm_s2 = 2222;
  int writes = 0;
  f.on_trace = [&](const TraceEvent& e) {
    if (!e.outgoing) return;
    if (e.bytes[1] == 0x10 && ++writes == 2) {
      sim::FaultConfig drop;
      drop.drop = 1.0;
      f.bus.set_faults(drop);  // the reply to step 5's write is lost
    } else {
      f.bus.set_faults({});  // the read that follows is answered
    }
  };
  f.sent.clear();
  const RestoreReport r = apply_restore(*f.client, plan_restore(*f.client, want));
  EXPECT_TRUE(r.ok());
  EXPECT_THAT(r.steps_with(StepOutcome::Written), ElementsAre(2u, 5u, 8u));
  EXPECT_EQ(r.steps[5].lost_replies, 1u);
  EXPECT_EQ(writes, 3);  // no write sent twice
  EXPECT_EQ(writes_sent(f.sent), 3u);
  for (unsigned n : {2u, 5u, 8u}) EXPECT_EQ(counters()[n], 1u) << "step " << n;
  EXPECT_EQ(controller_steps(), want.steps);
}

// Swallows the n-th write frame: it never reaches the twin (noise on the line).
class SwallowingLink final : public Link {
 public:
  SwallowingLink(Link& inner, int nth) : inner_(inner), nth_(nth) {}
  void write(std::span<const uint8_t> bytes) override {
    if (bytes.size() > 1 && bytes[1] == 0x10 && ++writes_ == nth_) return;
    inner_.write(bytes);
  }
  std::size_t read_some(std::span<uint8_t> buffer, TimePoint deadline) override {
    return inner_.read_some(buffer, deadline);
  }
  void discard_input() override { inner_.discard_input(); }
  const Clock& clock() const override { return inner_.clock(); }
  uint32_t baud() const override { return inner_.baud(); }
  std::string describe() const override { return inner_.describe(); }

 private:
  Link& inner_;
  int nth_;
  int writes_ = 0;
};

TEST_F(StepSync, AWriteThatNeverArrivedIsSentAgainAfterLooking) {
  StepTable want = backup_steps(*f.client);
  want.steps[6].speed_mm_s = 321;
  want.steps[7].speed_mm_s = 322;
  SwallowingLink swallowing(*f.link, 1);
  Client c(swallowing, f.options());
  f.sent.clear();
  const RestoreReport r = apply_restore(c, plan_restore(c, want));
  EXPECT_TRUE(r.ok());
  EXPECT_THAT(r.steps_with(StepOutcome::Written), ElementsAre(6u, 7u));
  EXPECT_EQ(r.steps[6].lost_replies, 1u);
  EXPECT_EQ(writes_sent(f.sent), 3u);  // step 6 twice (the first lost on the way), step 7 once
  EXPECT_EQ(counters()[6], 1u);
  EXPECT_EQ(counters()[7], 1u);
  EXPECT_EQ(controller_steps(), want.steps);
}

TEST_F(StepSync, CancelStopsBetweenSteps) {
  StepTable want = backup_steps(*f.client);
  for (unsigned n : {1u, 2u, 3u}) want.steps[n].speed_mm_s = 10;
  int asked = 0;
  ApplyOptions o;
  o.cancel = [&] { return ++asked > 1; };
  const RestoreReport r = apply_restore(*f.client, plan_restore(*f.client, want), o);
  EXPECT_EQ(r.failure, FailureKind::Cancelled);
  EXPECT_THAT(r.steps_with(StepOutcome::Written), ElementsAre(1u));
  EXPECT_THAT(r.steps_with(StepOutcome::NotAttempted), ElementsAre(2u, 3u));
  EXPECT_THAT(written_steps(), ElementsAre(1u));
}

// Ctrl-C that lands while a step's FC10 is on the wire (sent, reply not yet
// in): reported as cancelled, the step as possibly written, the rest not
// attempted; nothing escapes as an exception.
TEST_F(StepSync, ACancelMidTransactionIsReportedWithWhatMayBeWritten) {
  StepTable want = backup_steps(*f.client);
  for (unsigned n : {1u, 2u, 3u}) want.steps[n].speed_mm_s = 10;
  const RestorePlan plan = plan_restore(*f.client, want);
  bool interrupted = false;
  ClientOptions o;
  o.interrupted = [&] { return interrupted; };
  f.reconnect(o);
  int step_writes = 0;
  f.on_trace = [&](const TraceEvent& e) {
    // The second step's write is on the wire: Ctrl-C now.
    if (e.outgoing && e.bytes.size() > 1 && e.bytes[1] == 0x10 && ++step_writes == 2) {
      interrupted = true;
    }
  };
  RestoreReport r;
  ASSERT_NO_THROW(r = apply_restore(*f.client, plan));
  EXPECT_EQ(r.failure, FailureKind::Cancelled);
  EXPECT_THAT(r.steps_with(StepOutcome::Written), ElementsAre(1u));
  EXPECT_THAT(r.steps_with(StepOutcome::Failed), ElementsAre(2u));
  EXPECT_THAT(r.steps_with(StepOutcome::NotAttempted), ElementsAre(3u));
  EXPECT_TRUE(r.steps[2].maybe_written);
  EXPECT_THAT(r.steps[2].error, HasSubstr("interrupted"));
  EXPECT_THAT(r.summary(), HasSubstr("1 failed"));
}

TEST_F(StepSync, ABadFileGivesNoTableAndSoNothingToSend) {
  const auto t = read_table_file(data_path("bad_row.csv"));
  ASSERT_FALSE(t);
  EXPECT_THAT(t.error(), ElementsAre(AllOf(HasSubstr("line 5 (step 3)"), HasSubstr("speed_mm_s"),
                                           HasSubstr("allowed 1 to 65535"))));
  const auto missing = read_table_file("/nonexistent/steps.csv");
  ASSERT_FALSE(missing);
  EXPECT_THAT(missing.error()[0], HasSubstr("cannot read /nonexistent/steps.csv"));
  EXPECT_TRUE(f.sent.empty());
  EXPECT_TRUE(written_steps().empty());
}

TEST_F(StepSync, SpreadsheetFixturesRestoreAndThenDiffEmpty) {
  for (const char* name : {"spreadsheet_saved.csv", "semicolon_decimal_comma.csv",
                           "reordered_columns.csv", "press2.json"}) {
    SCOPED_TRACE(name);
    const auto t = read_table_file(data_path(name));
    ASSERT_TRUE(t) << t.error()[0];
    const RestoreReport r = apply_restore(*f.client, plan_restore(*f.client, *t));
    EXPECT_TRUE(r.ok());
    EXPECT_TRUE(diff_controller(*f.client, *t).equal());
    for (unsigned n : t->covered_steps())
      EXPECT_EQ(twin().eeprom().steps[n], t->steps[n]) << "step " << n;
    EXPECT_EQ(apply_restore(*f.client, plan_restore(*f.client, *t)).count(StepOutcome::Written),
              0u);
  }
  // press2.json: position -12.5 mm and area1 "-1.25" arrive to the 0.01 mm.
  EXPECT_EQ(twin().eeprom().steps[5].position_001mm, -1250);
  EXPECT_EQ(twin().eeprom().steps[5].area1_001mm, -125);
}

TEST_F(StepSync, BackupFilesRoundTripExactlyAlsoThroughASpreadsheet) {
  sim::Eeprom e = twin().eeprom();
  e.steps[11] = step(-1);  // -0.01 mm
  e.steps[11].area1_001mm = -2147483647;
  e.steps[11].area2_001mm = 2147483647;
  e.steps[11].in_position_001mm = 1;
  twin().restore_eeprom(e);
  const StepTable backup = backup_steps(*f.client);
  const auto dir =
      std::filesystem::temp_directory_path() / ("lec6-step-sync-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  for (const char* name : {"b.csv", "b.JSON"}) {
    SCOPED_TRACE(name);
    const auto path = dir / name;
    ASSERT_TRUE(write_table_file(path, backup));
    const auto back = read_table_file(path);
    ASSERT_TRUE(back) << back.error()[0];
    EXPECT_EQ(*back, backup);
  }
  // Written by a spreadsheet: BOM, CRLF, every cell quoted, ';' and decimal commas.
  std::string csv = lec::to_csv(backup);
  std::string sheet = "\xEF\xBB\xBF";
  std::istringstream lines(csv);
  for (std::string line; std::getline(lines, line);) {
    std::string row;
    std::stringstream cells(line);
    for (std::string cell; std::getline(cells, cell, ',');) {
      std::replace(cell.begin(), cell.end(), '.', ',');
      row += (row.empty() ? "\"" : ";\"") + cell + "\"";
    }
    sheet += row + ";;\r\n";
  }
  EXPECT_THAT(sheet, HasSubstr("\"11\";\"abs\";\"500\";\"-0,01\";"));
  const auto parsed = lec::parse_csv(sheet);
  ASSERT_TRUE(parsed) << parsed.error()[0];
  EXPECT_EQ(*parsed, backup);
  f.sent.clear();
  EXPECT_EQ(apply_restore(*f.client, plan_restore(*f.client, *parsed)).summary(),
            "0 steps written, 64 unchanged");
  EXPECT_EQ(writes_sent(f.sent), 0u);
  std::filesystem::remove_all(dir);
}

TEST_F(StepSync, DiffNamesTheFieldsOnEachSideAndWritesNothing) {
  const StepTable backup = backup_steps(*f.client);
  StepTable file = backup;
  file.steps[3].speed_mm_s = 650;
  file.steps[3].position_001mm = 15000;
  f.sent.clear();
  const StepDiff d = diff_controller(*f.client, file);
  EXPECT_EQ(writes_sent(f.sent), 0u);
  ASSERT_EQ(d.fields.size(), 2u);
  EXPECT_EQ(d.steps(), 1u);
  EXPECT_EQ(d.fields[0], (lec::StepFieldDiff{3, lec::StepField::Speed, "500", "650"}));
  EXPECT_EQ(d.fields[1], (lec::StepFieldDiff{3, lec::StepField::Position, "40.00", "150.00"}));
  EXPECT_TRUE(diff_controller(*f.client, backup).equal());
}

TEST_F(StepSync, DiffOfTwoControllers) {
  ClientOptions o = f.options();
  o.id = 2;
  Client second(*f.link, o);
  EXPECT_EQ(diff_controllers(*f.client, second).steps(), 10u);  // 2 is factory blank
  apply_restore(second, plan_restore(second, backup_steps(*f.client)));
  EXPECT_THAT(written_steps(2), ElementsAre(0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u, 9u));
  EXPECT_TRUE(diff_controllers(*f.client, second).equal());
  sim::Eeprom e = twin(2).eeprom();
  e.steps[63] = step(1);
  twin(2).restore_eeprom(e);
  const StepDiff d = diff_controllers(*f.client, second);
  EXPECT_EQ(d.steps(), 1u);
  EXPECT_EQ(d.fields.front().step, 63u);
  EXPECT_EQ(d.fields.front().value_a, "blank");
  EXPECT_EQ(d.fields.front().value_b, "abs");
}

TEST_F(StepSync, NotesANameOrIdTheFileWasNotSavedFrom) {
  StepTable t = backup_steps(*f.client);
  t.equipment_name = "PRESS 2";
  t.controller_id = 3;
  const RestorePlan plan = plan_restore(*f.client, t);
  EXPECT_EQ(plan.to_write(), 0u);
  ASSERT_EQ(plan.notes.size(), 2u);
  EXPECT_THAT(plan.notes[0], AllOf(HasSubstr("'PRESS 2'"), HasSubstr("read-only")));
  EXPECT_THAT(plan.notes[1], HasSubstr("controller ID 3, this is controller ID 1"));
  EXPECT_EQ(diff_controller(*f.client, t).notes, plan.notes);
}

TEST(StepSyncText, StepListsAreCompactRanges) {
  EXPECT_EQ(format_step_list({}), "none");
  EXPECT_EQ(format_step_list({5}), "5");
  EXPECT_EQ(format_step_list({0, 1, 2, 3, 5, 9, 10, 63}), "0-3, 5, 9-10, 63");
}

TEST(StepSyncText, PlanStepDescribesOneStep) {
  const RestorePlan p = plan_step(7, step(100), step(100, 250));
  ASSERT_EQ(p.steps.size(), 1u);
  EXPECT_EQ(p.steps[0].step, 7u);
  EXPECT_THAT(p.steps[0].fields, ElementsAre(lec::StepField::Speed));
  EXPECT_TRUE(plan_step(7, step(100), step(100)).steps[0].equal());
}

}  // namespace
}  // namespace lec6::client
