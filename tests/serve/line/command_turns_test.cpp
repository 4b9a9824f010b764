// Client commands take turns by source (line/command_turns.hpp), on the
// scheduler's virtual clock: an operator's command behind a SCADA flood, each
// source's own order, and the turn bound in random plants.

#include "line/command_turns.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>

#include "sanitized.hpp"
#include "serve/line/scheduler_harness.hpp"

namespace lec6::serve {
namespace {

using namespace scheduler_testing;

// A read of D9000 + `n` (no two the same: nothing is answered from a cache).
Job read_from(Harness& h, JobSource source, uint8_t id, uint16_t n) {
  Job j = h.job(Priority::Command, id, ReadRegistersRequest{static_cast<uint16_t>(0x9000 + n), 1});
  j.source = source;
  return j;
}

TEST(CommandTurns, AnOperatorsMoveGoesAfterOneReadPerScadaClientNotAfterTheFlood) {
  Harness h;
  // Twenty SCADA connections, eight reads each in flight (bench/stop_bench.py's flood).
  for (JobSource c = 1; c <= 20; ++c)
    for (uint16_t n = 0; n < 8; ++n) h.s.submit(read_from(h, c, 1, n), h.clock.now());
  // The HMI: a move's start (FC10 into D9102), its own connection.
  Job move = h.job(Priority::Command, 2,
                   modbus::WriteRegistersRequest::of(0x9102, std::vector<uint16_t>{0, 5000}));
  move.source = 99;
  h.s.submit(std::move(move), h.clock.now());
  int before = 0;
  while (auto d = h.step()) {
    if (d->frame.id == 2) break;
    ++before;
  }
  // One read of each SCADA connection (they were there first), not all 160.
  EXPECT_EQ(before, 20);
  EXPECT_EQ(h.results.size(), 21u);
}

TEST(CommandTurns, OneSourceAloneIsFirstInFirstOut) {
  Harness h;
  for (uint16_t n = 0; n < 10; ++n) h.s.submit(read_from(h, 7, 1, n), h.clock.now());
  std::vector<uint16_t> order;
  while (auto d = h.step())
    order.push_back(std::get<ReadRegistersRequest>(d->frame.pdu).start - 0x9000);
  EXPECT_EQ(order, (std::vector<uint16_t>{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}));
}

TEST(CommandTurns, ANewConnectionPerRequestNeitherJumpsTheQueueNorStarvesTheOthers) {
  Harness h;
  // Two connections that stay, with a backlog each.
  for (uint16_t n = 0; n < 30; ++n) {
    h.s.submit(read_from(h, 1, 1, n), h.clock.now());
    h.s.submit(read_from(h, 2, 1, static_cast<uint16_t>(100 + n)), h.clock.now());
  }
  // An HMI that opens a connection per request: its next request once the
  // last one is answered (each on a connection the scheduler never saw).
  JobSource fresh = 1000;
  std::map<JobSource, int> served;
  bool waiting = false;
  for (int t = 0; t < 60; ++t) {
    if (!waiting) {
      h.s.submit(read_from(h, fresh++, 1, static_cast<uint16_t>(200 + t)), h.clock.now());
      waiting = true;
    }
    auto d = h.step();
    ASSERT_TRUE(d);
    const uint16_t a = std::get<ReadRegistersRequest>(d->frame.pdu).start - 0x9000;
    ++served[a < 100 ? 1 : a < 200 ? 2 : 3];
    if (a >= 200) waiting = false;
  }
  // The line shared three ways: 20 transactions each, ± one turn.
  for (JobSource s : {1, 2, 3}) EXPECT_NEAR(served[s], 20, 1) << s;
}

// Random plants (60 under the sanitizers: sanitized.hpp): sources come and go with bursts of
// commands. Between two dispatches of a source that keeps commands queued, no other source goes
// twice, and each source's commands keep their order.
TEST(CommandTurns, NoSourceGoesTwiceBeforeAWaitingOneGoesOnceInRandomPlants) {
  for (uint64_t seed = 0; seed < testing::sanitized<uint64_t>(300, 60); ++seed) {
    std::mt19937_64 rng(seed);
    Harness h;
    std::map<JobSource, std::vector<uint16_t>> submitted, sent;
    std::map<JobSource, int> queued;
    std::map<JobSource, std::set<JobSource>> since;  // who went since each waiting source last went
    uint16_t n = 0;
    // One transaction: who went, checked against every source still waiting.
    auto take = [&]() -> bool {
      auto d = h.step();
      if (!d) return false;
      const uint16_t a = std::get<ReadRegistersRequest>(d->frame.pdu).start - 0x9000;
      JobSource src = 0;
      for (auto& [s, v] : submitted)
        if (std::find(v.begin(), v.end(), a) != v.end()) src = s;
      EXPECT_NE(src, 0u) << "seed " << seed;
      sent[src].push_back(a);
      --queued[src];
      for (auto& [s, went] : since) {
        if (s == src || queued[s] == 0) continue;
        EXPECT_TRUE(went.insert(src).second) << "seed " << seed << ": source " << src
                                             << " went twice while source " << s << " waited";
      }
      since[src].clear();
      return true;
    };
    for (int round = 0; round < 400; ++round) {
      if (rng() % 3 == 0) {
        const JobSource src = 1 + rng() % 12;
        for (int k = 1 + static_cast<int>(rng() % 6); k > 0; --k) {
          submitted[src].push_back(n);
          if (queued[src]++ == 0) since[src].clear();
          h.s.submit(read_from(h, src, 1, n++), h.clock.now());
        }
      }
      if (rng() % 5 != 0) take();  // else the line is busy with something else
    }
    while (take()) {
    }
    if (::testing::Test::HasFailure()) return;
    for (auto& [s, v] : submitted) {
      std::vector<uint16_t> got = sent[s];
      // Every command sent once, in its source's order.
      EXPECT_EQ(got, v) << "seed " << seed << " source " << s;
    }
    EXPECT_EQ(h.results.size(), static_cast<std::size_t>(n)) << "seed " << seed;
  }
}

// A source whose last job left the queue without its turn (cancelled here;
// answered from the cache, superseded by a stop or failed alike) comes back
// behind those already waiting: the turn it held is not kept (a reviewer's
// finding: it went ahead of them).
TEST(CommandTurns, ASourceWhoseJobWasCancelledComesBackBehindThoseWaiting) {
  Harness h;
  const JobId gone = h.s.submit(read_from(h, 1, 1, 0), h.clock.now());
  for (uint16_t n = 1; n <= 5; ++n) {
    h.s.submit(read_from(h, 2, 1, static_cast<uint16_t>(100 + n)), h.clock.now());
    h.s.submit(read_from(h, 3, 1, static_cast<uint16_t>(200 + n)), h.clock.now());
  }
  ASSERT_TRUE(h.s.cancel(gone, h.clock.now()));
  for (int k = 0; k < 4; ++k) ASSERT_TRUE(h.step());
  h.s.submit(read_from(h, 1, 1, 1), h.clock.now());
  std::vector<uint16_t> next;
  for (int k = 0; k < 3; ++k)
    next.push_back(std::get<ReadRegistersRequest>(h.step()->frame.pdu).start - 0x9000);
  // Sources 2 and 3 each once more (they waited), then source 1.
  EXPECT_EQ(next, (std::vector<uint16_t>{103, 203, 1}));
}

TEST(CommandTurns, ForgetsSourcesWithNothingQueued) {
  CommandTurns t;
  std::deque<Queued> q;
  for (JobSource s = 1; s <= 100; ++s) t.queued(s, false);
  EXPECT_EQ(t.known(), 100u);
  Queued one;
  one.job.source = 42;
  q.push_back(one);
  t.forget_idle(q);
  EXPECT_EQ(t.known(), 1u);
  EXPECT_EQ(t.pick(q)->job.source, 42u);
}

}  // namespace
}  // namespace lec6::serve
