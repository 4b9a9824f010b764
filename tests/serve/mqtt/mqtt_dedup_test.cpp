// The MQTT command log: a repeated id runs once, within bounds that never
// drop a running command.

#include "mqtt/mqtt_dedup.hpp"

#include <gtest/gtest.h>

#include <fmt/format.h>

namespace lec6::serve {
namespace {

using Seen = CommandLog::Seen;
using std::chrono::minutes;
using std::chrono::seconds;

const TimePoint t0{};

TEST(CommandLog, ANewIdRunsARunningOneWaitsADoneOneIsAnswered) {
  CommandLog log;
  EXPECT_EQ(log.find("a", t0).seen, Seen::New);
  log.start("a", t0);
  EXPECT_EQ(log.find("a", t0 + seconds(1)).seen, Seen::Running);
  log.finish("a", R"({"id":"a","ok":true})", t0 + seconds(2));
  const auto again = log.find("a", t0 + seconds(3));
  EXPECT_EQ(again.seen, Seen::Done);
  EXPECT_EQ(again.result, R"({"id":"a","ok":true})");
  EXPECT_EQ(log.find("b", t0).seen, Seen::New);
}

TEST(CommandLog, RepliesOfRepeatsWhileRunningAreToldOnceWhenItEnds) {
  CommandLog log;
  log.start("a", t0, {{"reply/1", "c1"}});
  log.find("a", t0, {{"reply/2", "c2"}});
  log.find("a", t0, {{"reply/1", "c1"}});  // the same requester again: once
  const auto to = log.finish("a", "{}", t0);
  ASSERT_EQ(to.size(), 2u);
  EXPECT_EQ(to[0].topic, "reply/1");
  EXPECT_EQ(to[1].correlation, "c2");
  // Finishing twice (or an unknown id) tells no one.
  EXPECT_TRUE(log.finish("a", "{}", t0).empty());
  EXPECT_TRUE(log.finish("zz", "{}", t0).empty());
}

TEST(CommandLog, FinishedEntriesExpireAfterMaxAge) {
  CommandLog log({.max_entries = 100, .max_age = minutes(60), .max_bytes = 1 << 20});
  log.start("a", t0);
  log.finish("a", "{}", t0);
  EXPECT_EQ(log.find("a", t0 + minutes(59)).seen, Seen::Done);
  EXPECT_EQ(log.find("a", t0 + minutes(61)).seen, Seen::New);
  EXPECT_EQ(log.size(), 0u);
}

TEST(CommandLog, TheOldestFinishedGoFirstPastMaxEntries) {
  CommandLog log({.max_entries = 3, .max_age = minutes(60), .max_bytes = 1 << 20});
  for (int i = 0; i < 5; ++i) {
    const auto id = fmt::format("c{}", i);
    log.start(id, t0);
    log.finish(id, "{}", t0 + seconds(i));
  }
  EXPECT_EQ(log.size(), 3u);
  EXPECT_EQ(log.find("c0", t0 + seconds(10)).seen, Seen::New);
  EXPECT_EQ(log.find("c1", t0 + seconds(10)).seen, Seen::New);
  EXPECT_EQ(log.find("c2", t0 + seconds(10)).seen, Seen::Done);
  EXPECT_EQ(log.find("c4", t0 + seconds(10)).seen, Seen::Done);
}

TEST(CommandLog, ResultBytesAreBounded) {
  CommandLog log({.max_entries = 100, .max_age = minutes(60), .max_bytes = 1000});
  for (int i = 0; i < 5; ++i) {
    const auto id = fmt::format("c{}", i);
    log.start(id, t0);
    log.finish(id, std::string(400, 'x'), t0);
  }
  EXPECT_LE(log.bytes(), 1000u);
  EXPECT_EQ(log.size(), 2u);
  EXPECT_EQ(log.find("c4", t0).seen, Seen::Done);
}

TEST(CommandLog, ARunningCommandIsNeverDropped) {
  CommandLog log({.max_entries = 2, .max_age = seconds(1), .max_bytes = 10});
  log.start("long", t0);
  for (int i = 0; i < 10; ++i) {
    const auto id = fmt::format("c{}", i);
    log.start(id, t0);
    log.finish(id, std::string(50, 'x'), t0);
  }
  // Hours later, however full: a repeat of the running one must not run again.
  EXPECT_EQ(log.find("long", t0 + minutes(120)).seen, Seen::Running);
  log.finish("long", "{}", t0 + minutes(120));
  EXPECT_EQ(log.find("long", t0 + minutes(120)).seen, Seen::Done);
}

}  // namespace
}  // namespace lec6::serve
