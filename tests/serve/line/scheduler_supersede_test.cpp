// A hard stop supersedes the writes queued before it to its controller that
// would start or resume motion (scheduler.cpp, docs/protocol-decisions.md "A
// stop supersedes"): they are refused, the stop goes to the wire next, and
// nothing queued before it moves the axis after it. A release (the second half
// of a pulse) keeps the earlier writes in order ahead of it.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "lec6/client/interrupt.hpp"
#include "lec6/lec/memory_map.hpp"
#include "modbus_tcp/gateway.hpp"
#include "ops/op_results.hpp"
#include "serve/line/scheduler_harness.hpp"

namespace lec6::serve {
// Named, not anonymous: the unity build puts scheduler_stop_test.cpp's kResetOn in the same unit.
namespace supersede_testing {

using namespace scheduler_testing;
using modbus::WriteCoilRequest;
using ::testing::HasSubstr;

const modbus::Request kDriveOn = WriteCoilRequest{0x1A, modbus::kCoilOn};
const modbus::Request kDriveOff = WriteCoilRequest{0x1A, modbus::kCoilOff};
const modbus::Request kHoldOn = WriteCoilRequest{0x18, modbus::kCoilOn};
const modbus::Request kHoldOff = WriteCoilRequest{0x18, modbus::kCoilOff};
const modbus::Request kJogOn = WriteCoilRequest{0x1D, modbus::kCoilOn};
const modbus::Request kJogOff = WriteCoilRequest{0x1D, modbus::kCoilOff};
const modbus::Request kResetOn = WriteCoilRequest{0x1B, modbus::kCoilOn};
const modbus::Request kSelectStep3 = modbus::WriteCoilsRequest::of(
    0x10, std::array<bool, 8>{true, true, false, false, false, false, false, false});

modbus::Request direct_start() {
  const uint16_t v[] = {lec::kDirectStartValue};
  return modbus::WriteRegistersRequest::of(lec::kDirectStart, v);
}

struct Submitted {
  std::vector<std::pair<std::string, JobResult>> results;
};

// Submits `r` to `id` at Command priority, or where the gateway's rule puts it.
void submit(Harness& h, Submitted& out, std::string name, uint8_t id, modbus::Request r,
            int attempts = 3) {
  Job j;
  j.priority = client::stops_or_releases(r) ? Priority::Emergency : Priority::Command;
  j.frame = {id, std::move(r)};
  j.attempts = attempts;
  j.done = [&out, name = std::move(name)](const JobResult& res) {
    out.results.emplace_back(name, res);
  };
  h.s.submit(std::move(j), h.clock.now());
  for (auto& c : h.s.take_completions()) c.done(c.result);
}

// As submit(), for a write of one of lec serve's operations: one attempt,
// dated at its command's acceptance (Job::command_accepted).
void submit_accepted(Harness& h, Submitted& out, std::string name, uint8_t id, modbus::Request r,
                     TimePoint accepted, std::vector<uint8_t> stop_group = {}) {
  Job j;
  j.stop_group = std::move(stop_group);
  j.priority = client::stops_or_releases(r) ? Priority::Emergency : Priority::Command;
  j.frame = {id, std::move(r)};
  j.command_accepted = accepted;
  j.done = [&out, name = std::move(name)](const JobResult& res) {
    out.results.emplace_back(name, res);
  };
  h.s.submit(std::move(j), h.clock.now());
  for (auto& c : h.s.take_completions()) c.done(c.result);
}

const JobResult& result_of(const Submitted& s, const std::string& name) {
  for (const auto& [n, r] : s.results)
    if (n == name) return r;
  throw std::runtime_error("no result for " + name);
}

// Puts a read of `id` on the wire (the line busy when the test's writes come).
Dispatch occupy(Harness& h, uint8_t id) {
  h.s.submit(h.job(Priority::Command, id), h.clock.now());
  auto d = h.s.next(h.clock.now());
  EXPECT_TRUE(d);
  return d.value_or(Dispatch{});
}

// Ends the exchange on the wire: answered after 10 ms.
void answer_it(Harness& h, const Dispatch& d) {
  h.clock.advance(10ms);
  h.s.completed(answer(d), h.clock.now() - 10ms, h.clock.now());
  for (auto& c : h.s.take_completions()) c.done(c.result);
}

TEST(SchedulerSupersede, AHoldGoesFirstAndTheStartsQueuedBeforeItAreRefused) {
  Harness h;
  Submitted s;
  const Dispatch first = occupy(h, 2);
  submit(h, s, "select", 1, kSelectStep3);
  submit(h, s, "drive", 1, kDriveOn);
  submit(h, s, "start", 1, direct_start());
  submit(h, s, "hold off", 1, kHoldOff);
  submit(h, s, "drive on 2", 2, kDriveOn);  // another controller's: untouched
  submit(h, s, "hold", 1, kHoldOn);
  // The three writes that would move ID 1 are refused at once, saying why.
  for (const char* name : {"drive", "start", "hold off"}) {
    const JobResult& r = result_of(s, name);
    EXPECT_EQ(r.failure, Failure::Superseded) << name;
    EXPECT_THAT(r.error, HasSubstr("stop to ID 1")) << name;
  }
  // The exchange on the wire ends; ID 1's other write queued before the HOLD
  // (a step selection) goes first, in order, then the HOLD, then the rest.
  answer_it(h, first);
  std::vector<std::pair<uint8_t, modbus::Request>> wire;
  for (const auto& d : h.run_for(1s)) wire.emplace_back(d.frame.id, d.frame.pdu);
  ASSERT_GE(wire.size(), 3u);
  EXPECT_EQ(wire[0], (std::pair<uint8_t, modbus::Request>{1, kSelectStep3}));
  EXPECT_EQ(wire[1], (std::pair<uint8_t, modbus::Request>{1, kHoldOn}));
  std::vector<std::pair<uint8_t, modbus::Request>> rest(wire.begin() + 2, wire.end());
  EXPECT_THAT(rest, ::testing::Contains(std::pair<uint8_t, modbus::Request>{2, kDriveOn}));
  for (const auto& [id, pdu] : rest) {
    EXPECT_FALSE(id == 1 && client::starts_motion(pdu)) << "a start to ID 1 went after its HOLD";
  }
  EXPECT_EQ(result_of(s, "hold").failure, Failure::None);
  // Counted per controller (lec serve's /api/lines and /metrics), none of
  // them a transaction: they never went on the wire.
  const auto snap = h.s.stats(h.clock.now());
  EXPECT_EQ(snap.devices.at(1).superseded, 3u);
  EXPECT_EQ(snap.devices.count(2) ? snap.devices.at(2).superseded : 0u, 0u);
}

TEST(SchedulerSupersede, AReleaseKeepsTheWritesBeforeItInOrder) {
  // JOG+ <- 1 then JOG+ <- 0 (a short jog pressed and let go): the release
  // must not eat its own start; both go, in order.
  Harness h;
  Submitted s;
  occupy(h, 2);
  submit(h, s, "jog", 1, kJogOn);
  submit(h, s, "release", 1, kJogOff);
  submit(h, s, "drive", 1, kDriveOn);
  submit(h, s, "drive off", 1, kDriveOff);
  h.clock.advance(10ms);
  h.s.failed(kTimeout, h.clock.now() - 10ms, h.clock.now());
  for (auto& c : h.s.take_completions()) c.done(c.result);
  std::vector<modbus::Request> to_1;
  for (const auto& d : h.run_for(1s))
    if (d.frame.id == 1) to_1.push_back(d.frame.pdu);
  EXPECT_EQ(to_1, (std::vector<modbus::Request>{kJogOn, kJogOff, kDriveOn, kDriveOff}));
  for (const auto& [name, r] : s.results) EXPECT_EQ(r.failure, Failure::None) << name;
}

TEST(SchedulerSupersede, AStartWhoseReplyWasLostIsNotResentAfterAStopAcceptedMeanwhile) {
  Harness h;
  Submitted s;
  submit(h, s, "drive", 1, kDriveOn);
  const auto d = h.s.next(h.clock.now());  // DRIVE <- 1 on the wire
  ASSERT_TRUE(d);
  ASSERT_EQ(d->frame.pdu, kDriveOn);
  submit(h, s, "reset", 1, kResetOn);  // the operator's stop, while it is out
  h.clock.advance(65ms);
  h.s.failed(kTimeout, h.clock.now() - 65ms, h.clock.now());  // its reply is lost
  for (auto& c : h.s.take_completions()) c.done(c.result);
  EXPECT_EQ(result_of(s, "drive").failure, Failure::Superseded);
  std::vector<modbus::Request> wire;
  for (const auto& x : h.run_for(1s)) wire.push_back(x.frame.pdu);
  EXPECT_EQ(wire, (std::vector<modbus::Request>{kResetOn}));
}

TEST(SchedulerSupersede, AStartAcceptedAfterTheStopIsNotRefused) {
  Harness h;
  Submitted s;
  submit(h, s, "hold", 1, kHoldOn);
  submit(h, s, "hold off", 1, kHoldOff);  // the operator resumes: a new command
  h.run_for(1s);
  EXPECT_EQ(result_of(s, "hold").failure, Failure::None);
  EXPECT_EQ(result_of(s, "hold off").failure, Failure::None);
}

// A machine cycle's writes carry its axes on the line (Job::stop_group): a
// hard stop to one of them refuses the cycle's starts to the others, queued
// or submitted later (a reviewer's finding: a stop of axis 2 left the
// cycle's start of axis 1, already queued, to go after it). A start to
// axis 1 outside the cycle is not refused by axis 2's stop.
TEST(SchedulerSupersede, AStopOfOneAxisOfACycleRefusesTheCyclesStartsOfItsOtherAxes) {
  Harness h;
  Submitted s;
  const Dispatch first = occupy(h, 3);
  const TimePoint looked = h.clock.now();
  submit_accepted(h, s, "cycle drive 1", 1, kDriveOn, looked, {1, 2});
  h.clock.advance(1ms);
  submit(h, s, "hold 2", 2, kHoldOn);
  EXPECT_EQ(result_of(s, "cycle drive 1").failure, Failure::Superseded);
  submit_accepted(h, s, "cycle drive 1 later", 1, kDriveOn, looked, {1, 2});
  EXPECT_EQ(result_of(s, "cycle drive 1 later").failure, Failure::Superseded);
  submit(h, s, "drive 1 alone", 1, kDriveOn);
  answer_it(h, first);
  h.run_for(1s);
  EXPECT_EQ(result_of(s, "hold 2").failure, Failure::None);
  EXPECT_EQ(result_of(s, "drive 1 alone").failure, Failure::None);
}

TEST(SchedulerSupersede, ABroadcastStopSupersedesEveryControllersStarts) {
  Harness h;
  Submitted s;
  occupy(h, 3);
  submit(h, s, "drive 1", 1, kDriveOn);
  submit(h, s, "drive 2", 2, kDriveOn);
  submit(h, s, "hold all", modbus::kBroadcastId, kHoldOn);
  EXPECT_EQ(result_of(s, "drive 1").failure, Failure::Superseded);
  EXPECT_EQ(result_of(s, "drive 2").failure, Failure::Superseded);
}

// A reviewer's finding: a start a release had moved into the emergency lane
// (DRIVE <- 1, then RESET <- 0) went to the wire ahead of the HOLD after them.
TEST(SchedulerSupersede, AStartAReleaseMovedIntoTheLaneIsRefusedToo) {
  Harness h;
  Submitted s;
  const Dispatch first = occupy(h, 2);
  submit(h, s, "drive", 1, kDriveOn);
  submit(h, s, "release", 1, modbus::WriteCoilRequest{0x1B, modbus::kCoilOff});
  submit(h, s, "hold", 1, kHoldOn);
  EXPECT_EQ(result_of(s, "drive").failure, Failure::Superseded);
  answer_it(h, first);
  std::vector<modbus::Request> to_1;
  for (const auto& d : h.run_for(1s))
    if (d.frame.id == 1) to_1.push_back(d.frame.pdu);
  EXPECT_EQ(to_1, (std::vector<modbus::Request>{modbus::WriteCoilRequest{0x1B, modbus::kCoilOff},
                                                kHoldOn}));
}

// A reviewer's finding: a broadcast start queued before a stop to one
// controller reached the wire after that stop (it starts that controller too).
TEST(SchedulerSupersede, ABroadcastStartQueuedBeforeAStopToOneControllerIsRefused) {
  Harness h;
  Submitted s;
  occupy(h, 2);
  submit(h, s, "drive all", modbus::kBroadcastId, kDriveOn);
  submit(h, s, "hold 1", 1, kHoldOn);
  EXPECT_EQ(result_of(s, "drive all").failure, Failure::Superseded);
}

// A reviewer's finding: lec serve's own operations resend a write whose reply
// was lost as a new job (Client's retries through LineMaster); a stop accepted
// after the first attempt supersedes the resend too (Job::first_submitted).
TEST(SchedulerSupersede, AResendOfALostStartIsRefusedAfterAStopThatCameAfterTheFirstAttempt) {
  Harness h;
  Submitted s;
  submit(h, s, "drive", 1, kDriveOn, 1);  // one attempt: as every write gets (gateway, LineMaster)
  Job resend;
  ASSERT_TRUE(h.s.next(h.clock.now()));
  h.clock.advance(65ms);
  h.s.failed(kTimeout, h.clock.now() - 65ms, h.clock.now());
  for (auto& c : h.s.take_completions()) c.done(c.result);
  const JobResult lost = result_of(s, "drive");
  ASSERT_EQ(lost.failure, Failure::NoAnswer);  // one attempt: the Client resends
  submit(h, s, "reset", 1, kResetOn);
  h.clock.advance(1ms);
  resend.priority = Priority::Command;
  resend.frame = {1, kDriveOn};
  resend.first_submitted = lost.submitted;
  resend.done = [&s](const JobResult& r) { s.results.emplace_back("resend", r); };
  h.s.submit(std::move(resend), h.clock.now());
  for (auto& c : h.s.take_completions()) c.done(c.result);
  EXPECT_EQ(result_of(s, "resend").failure, Failure::Superseded);
  // A new start, not a resend, after the stop: carried out.
  submit(h, s, "new drive", 1, kDriveOn);
  h.run_for(1s);
  EXPECT_EQ(result_of(s, "new drive").failure, Failure::None);
}

// An operation's start comes after its reads (a move reads the flags and
// the state, writes the direct data, then starts): a stop accepted after the
// command, before the start reaches the line, supersedes the start all the
// same (Job::command_accepted; the Sparkplug attack's DCMD move raced by a
// stop 1.4 ms later moved the axis after the stop's "stopped"). A command
// accepted after the stop is carried out.
TEST(SchedulerSupersede, AStartOfACommandAcceptedBeforeTheStopIsRefusedHoweverLateItComes) {
  Harness h;
  Submitted s;
  const TimePoint move_accepted = h.clock.now();
  h.clock.advance(1ms);
  submit(h, s, "reset", 1, kResetOn);  // the stop, while the move is still reading
  h.run_for(100ms);
  submit_accepted(h, s, "start", 1, direct_start(), move_accepted);
  const JobResult& r = result_of(s, "start");
  EXPECT_EQ(r.failure, Failure::Superseded);
  EXPECT_THAT(r.error, HasSubstr("a stop to ID 1 accepted after it came first"));
  // Step data written by the same command is not a start: carried out.
  const uint16_t v[] = {10000, 0};
  submit_accepted(h, s, "data", 1, modbus::WriteRegistersRequest::of(lec::kDirectData, v),
                  move_accepted);
  h.run_for(100ms);
  EXPECT_EQ(result_of(s, "data").failure, Failure::None);
  // The next command, accepted after the stop: its start goes.
  submit_accepted(h, s, "next", 1, direct_start(), h.clock.now());
  h.run_for(100ms);
  EXPECT_EQ(result_of(s, "next").failure, Failure::None);
}

// The other way round (a reviewer's finding): a reset accepted before a
// move, whose RESET <- 1 reaches the line after the move was accepted (it
// follows its RESET <- 0's exchange), is dated at its acceptance: the move
// came after it and goes. A later write of that earlier stop never moves the
// date of a newer stop back.
TEST(SchedulerSupersede, AStopAcceptedBeforeACommandDoesNotRefuseItWhenItsWriteComesLater) {
  Harness h;
  Submitted s;
  const TimePoint reset_accepted = h.clock.now();
  h.clock.advance(2ms);
  const TimePoint move_accepted = h.clock.now();
  h.clock.advance(3ms);
  submit_accepted(h, s, "reset", 1, kResetOn, reset_accepted);
  h.run_for(50ms);
  submit_accepted(h, s, "start", 1, direct_start(), move_accepted);
  h.run_for(50ms);
  EXPECT_EQ(result_of(s, "start").failure, Failure::None) << result_of(s, "start").error;
  // A stop accepted after that move, then a late write of the old reset: the
  // newer stop's date stands, and a start of a command between them is refused.
  const TimePoint second_move = h.clock.now();
  h.clock.advance(1ms);
  submit(h, s, "stop", 1, kResetOn);
  submit_accepted(h, s, "old reset", 1, kResetOn, reset_accepted);
  h.run_for(50ms);
  submit_accepted(h, s, "late", 1, direct_start(), second_move);
  EXPECT_EQ(result_of(s, "late").failure, Failure::Superseded);
}

// Modbus TCP: a superseded write is answered with exception 04 (not carried
// out), never 0B (which would say the controller is dead).
TEST(SchedulerSupersede, TheGatewayAnswersASupersededWriteWithException04) {
  JobResult r;
  r.failure = Failure::Superseded;
  const auto reply = tcp_reply(modbus::RequestFrame{1, kDriveOn}, r);
  ASSERT_TRUE(reply);
  const auto* ex = std::get_if<modbus::ExceptionResponse>(&*reply);
  ASSERT_TRUE(ex);
  EXPECT_EQ(ex->code, modbus::ExceptionCode::ServerDeviceFailure);
}

// A reviewer's finding: a broadcast write that starts nothing (Y30 <- 0: the
// parallel inputs take over) queued before a stop to ID 1 went after it; and
// for a broadcast stop, other controllers' earlier writes could take their
// turns after the stop's. Every earlier write goes first.
TEST(SchedulerSupersede, EarlierWritesGoBeforeTheStopWhicheverControllerTheyAreFor) {
  const modbus::Request parallel = WriteCoilRequest{0x30, modbus::kCoilOff};
  {
    Harness h;
    Submitted s;
    const Dispatch first = occupy(h, 2);
    submit(h, s, "parallel all", modbus::kBroadcastId, parallel);
    submit(h, s, "hold 1", 1, kHoldOn);
    answer_it(h, first);
    std::vector<std::pair<uint8_t, modbus::Request>> wire;
    for (const auto& d : h.run_for(1s)) wire.emplace_back(d.frame.id, d.frame.pdu);
    EXPECT_EQ(wire, (std::vector<std::pair<uint8_t, modbus::Request>>{
                        {modbus::kBroadcastId, parallel}, {1, kHoldOn}}));
  }
  {
    Harness h;
    Submitted s;
    const Dispatch first = occupy(h, 3);
    submit(h, s, "select 1", 1, kSelectStep3);
    submit(h, s, "select 2", 2, kSelectStep3);
    submit(h, s, "hold all", modbus::kBroadcastId, kHoldOn);
    answer_it(h, first);
    std::vector<uint8_t> ids;
    for (const auto& d : h.run_for(1s)) ids.push_back(d.frame.id);
    EXPECT_EQ(ids, (std::vector<uint8_t>{1, 2, modbus::kBroadcastId}));
  }
}

// lec serve's own operations (HTTP, MQTT, Sparkplug) see a superseded start
// as the stop it is: 422 "stopped", never 503 "line down" (a reviewer's
// finding: it came through as a port error).
TEST(SchedulerSupersede, AnOperationWhoseStartWasSupersededSaysItWasStopped) {
  const OpResult r = serve::result_of(
      std::make_exception_ptr(client::Superseded("not carried out: a stop to ID 1 ...")), false);
  EXPECT_EQ(r.status, 422);
  EXPECT_EQ(r.body.value("outcome", ""), "stopped");
  EXPECT_THAT(r.body.dump(), HasSubstr("a stop to ID 1"));
}

}  // namespace supersede_testing
}  // namespace lec6::serve
