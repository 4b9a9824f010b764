// The history as the daemon uses it: records numbered across restarts, the
// odometer persistent, service notices, drift warnings in the health and to
// the listeners (SSE, MQTT).

#include "serve/history/history.hpp"
#include "temp_dir.hpp"

#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <future>
#include <random>
#include <thread>

namespace lec6::serve::history {
namespace {

namespace fs = std::filesystem;

using testing::TempDir;

// The wall clock the history sees; records start near it (retention keeps them).
constexpr int64_t kT0 = 1'790'000'000'000;
int64_t now() {
  return kT0 + 1'000'000;
}

MotionRecord move(double duration_s, double thrust, int64_t start_ms) {
  MotionRecord r;
  r.start_ms = kT0 + start_ms;
  r.axis = "x";
  r.source = "mqtt";
  r.kind = "move";
  r.start_mm = 10;
  r.target_mm = 150;
  r.speed_mm_s = 100;
  r.outcome = "reached";
  r.duration_s = duration_s;
  r.settle_s = 0.04;
  r.peak_thrust_pct = thrust;
  r.distance_mm = 140;
  return r;
}

void quiet(LogLevel, std::string_view) {}

TEST(History, TheOdometerAndTheRecordIdsCarryOnAfterARestart) {
  TempDir dir;
  HistoryConfig c;
  c.state_dir = dir.path;
  {
    History h(c, {"x"}, quiet, now);
    for (int i = 0; i < 10; ++i) h.record(move(1.4, 40, 1000 + i));
    h.flush();
  }
  History h(c, {"x"}, quiet, now);
  const auto health = h.health("x");
  EXPECT_EQ(health["odometer"]["moves"], 10);
  EXPECT_DOUBLE_EQ(health["odometer"]["distance_m"].get<double>(), 1.4);
  h.record(move(1.4, 40, 2000));
  h.flush();
  HistoryQuery q;
  q.axis = "x";
  const auto records = h.query(q);
  ASSERT_EQ(records.size(), 11u);
  EXPECT_EQ(records.front().id, 11);
}

TEST(History, AServiceThresholdRaisesANoticeUntilTheServiceIsDone) {
  TempDir dir;
  HistoryConfig c;
  c.state_dir = dir.path;
  c.services.push_back({"lubricate", std::nullopt, 20.0, std::nullopt});
  History h(c, {"x"}, quiet, now);
  for (int i = 0; i < 19; ++i) h.record(move(1.4, 40, i));
  EXPECT_TRUE(h.health("x")["service"].empty());
  h.record(move(1.4, 40, 20));
  const auto due = h.health("x");
  ASSERT_EQ(due["service"].size(), 1u);
  EXPECT_EQ(due["service"][0]["what"], "lubricate");
  EXPECT_FALSE(due["ok"].get<bool>());
  EXPECT_FALSE(h.serviced("x", "paint"));
  EXPECT_TRUE(h.serviced("x", "lubricate"));
  EXPECT_TRUE(h.health("x")["service"].empty());
}

TEST(History, TheServiceMarkPersists) {
  TempDir dir;
  HistoryConfig c;
  c.state_dir = dir.path;
  c.services.push_back({"lubricate", std::nullopt, 20.0, std::nullopt});
  {
    History h(c, {"x"}, quiet, now);
    for (int i = 0; i < 20; ++i) h.record(move(1.4, 40, i));
    EXPECT_TRUE(h.serviced("x", "lubricate"));
  }
  History again(c, {"x"}, quiet, now);
  EXPECT_TRUE(again.health("x")["service"].empty());
}

TEST(History, ListenersGetEachRecordTheDriftWarningAndTheHealth) {
  TempDir dir;
  HistoryConfig c;
  c.state_dir = dir.path;
  History h(c, {"x"}, quiet, now);
  std::vector<std::string> kinds;
  nlohmann::json last_drift;
  h.add_listener([&](const std::string& axis, std::string_view kind, const nlohmann::json& j) {
    EXPECT_EQ(axis, "x");
    kinds.emplace_back(kind);
    if (kind == "drift") last_drift = j;
  });
  std::mt19937 rng(1);
  std::normal_distribution<double> n(0, 0.01);
  for (int i = 0; i < 40; ++i) h.record(move(1.4 * (1 + n(rng)), 40 * (1 + n(rng)), i * 1000));
  for (int i = 40; i < 60; ++i) h.record(move(1.4 * 1.2, 40 * (1 + n(rng)), i * 1000));
  EXPECT_EQ(std::count(kinds.begin(), kinds.end(), "history"), 60);
  EXPECT_EQ(std::count(kinds.begin(), kinds.end(), "health"), 60);
  ASSERT_EQ(std::count(kinds.begin(), kinds.end(), "drift"), 1);
  EXPECT_TRUE(last_drift["raised"].get<bool>());
  EXPECT_EQ(last_drift["metric"], "duration_s");
  const auto health = h.health("x");
  ASSERT_EQ(health["warnings"].size(), 1u);
  EXPECT_NE(health["warnings"][0]["message"].get<std::string>().find("rose"), std::string::npos);
  EXPECT_EQ(health["groups"].size(), 1u);
}

TEST(History, AStepWriteThroughLecServeStartsANewBaseline) {
  TempDir dir;
  HistoryConfig c;
  c.state_dir = dir.path;
  History h(c, {"x"}, quiet, now);
  auto step_move = [](double d, int64_t t) {
    auto r = move(d, 40, t);
    r.kind = "run-step";
    r.step = 4;
    r.speed_mm_s.reset();
    return r;
  };
  for (int i = 0; i < 40; ++i) h.record(step_move(1.4, i));
  h.on_op_event("x", {{"event", "finished"}, {"op", "step-write"}, {"ok", true}, {"step", 4}},
                TimePoint{});
  for (int i = 40; i < 100; ++i) h.record(step_move(2.0, i));
  EXPECT_TRUE(h.health("x")["warnings"].empty());
}

TEST(History, RefusedMovesDoNotCountOnTheOdometer) {
  // Issue 32: five moves refused before anything was sent gave "moves: 5,
  // alarms: 5" and a lubrication notice.
  TempDir dir;
  HistoryConfig c;
  c.state_dir = dir.path;
  c.services.push_back({"lubricate", std::nullopt, 5.0, std::nullopt});
  History h(c, {"x"}, quiet, now);
  for (int i = 0; i < 5; ++i) {
    h.on_op_event("x", {{"event", "started"}, {"op", "move"}, {"source", "mqtt"}}, TimePoint{});
    h.on_op_event("x",
                  {{"event", "finished"},
                   {"op", "move"},
                   {"status", 422},
                   {"outcome", "alarm"},
                   {"alarms", {{{"code", 51}}}},
                   {"error", "the move (alarm already active): alarm 51"}},
                  TimePoint{});
  }
  const auto health = h.health("x");
  EXPECT_EQ(health["odometer"]["moves"], 0);
  EXPECT_EQ(health["odometer"]["alarms"], 0);
  EXPECT_TRUE(health["service"].empty());
  h.flush();
  HistoryQuery q;
  q.axis = "x";
  const auto records = h.query(q);
  ASSERT_EQ(records.size(), 5u);  // kept as events
  EXPECT_EQ(records.front().outcome, "refused");
}

TEST(History, ADriftWarningRaisedBeforeARestartIsStillRaisedAfterIt) {
  // Issue 32: a restart cleared every warning (/health said ok).
  TempDir dir;
  HistoryConfig c;
  c.state_dir = dir.path;
  std::mt19937 rng(2);
  std::normal_distribution<double> n(0, 0.01);
  nlohmann::json before;
  {
    History h(c, {"x"}, quiet, now);
    for (int i = 0; i < 40; ++i) h.record(move(1.4 * (1 + n(rng)), 40, i * 1000));
    for (int i = 40; i < 60; ++i) h.record(move(1.4 * 1.2, 40, i * 1000));
    before = h.health("x");
    ASSERT_EQ(before["warnings"].size(), 1u);
  }
  History h(c, {"x"}, quiet, now);
  const auto after = h.health("x");
  EXPECT_FALSE(after["ok"].get<bool>());
  ASSERT_EQ(after["warnings"].size(), 1u);
  EXPECT_EQ(after["warnings"][0]["message"], before["warnings"][0]["message"]);
  EXPECT_EQ(after["warnings"][0]["moves"], before["warnings"][0]["moves"]);
  EXPECT_EQ(after["groups"][0]["baseline"], before["groups"][0]["baseline"]);
  EXPECT_EQ(after["groups"][0]["moves"], before["groups"][0]["moves"]);
  // And it clears as it would have: back to normal after a lubrication.
  std::vector<bool> cleared;
  h.add_listener([&](const std::string&, std::string_view kind, const nlohmann::json& j) {
    if (kind == "drift") cleared.push_back(!j["raised"].get<bool>());
  });
  for (int i = 60; i < 75; ++i) h.record(move(1.4, 40, i * 1000));
  EXPECT_EQ(cleared, std::vector<bool>{true});
  EXPECT_TRUE(h.health("x")["warnings"].empty());
}

TEST(History, WearAcrossRestartsIsSeen) {
  // Issue 32: the baseline was learned again after each restart, from the
  // already worn actuator. Here each restart comes after 15 moves, and each
  // run is 4 % slower than the one before: only a kept baseline sees it.
  TempDir dir;
  HistoryConfig c;
  c.state_dir = dir.path;
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 0.005);
  int64_t t = 0;
  bool warned = false;
  for (int run = 0; run < 8 && !warned; ++run) {
    History h(c, {"x"}, quiet, now);
    const double slower = 1 + 0.04 * run;
    for (int i = 0; i < 25; ++i, t += 1000) h.record(move(1.4 * slower * (1 + n(rng)), 40, t));
    warned = !h.health("x")["warnings"].empty();
    if (warned) {
      EXPECT_GE(run, 3) << "warned before 10 % of wear";
    }
  }
  EXPECT_TRUE(warned) << "+28 % over 8 restarts, never warned";
}

TEST(History, AStepEditBeforeARestartStillRebasesAfterIt) {
  TempDir dir;
  HistoryConfig c;
  c.state_dir = dir.path;
  auto step_move = [](double d, int64_t t) {
    auto r = move(d, 40, t);
    r.kind = "run-step";
    r.step = 4;
    r.speed_mm_s.reset();
    return r;
  };
  {
    History h(c, {"x"}, quiet, now);
    for (int i = 0; i < 40; ++i) h.record(step_move(1.4, i));
    h.on_op_event("x", {{"event", "finished"}, {"op", "step-write"}, {"ok", true}, {"step", 4}},
                  TimePoint{});
  }
  History h(c, {"x"}, quiet, now);
  for (int i = 40; i < 100; ++i) h.record(step_move(2.0, i));
  EXPECT_TRUE(h.health("x")["warnings"].empty());
}

TEST(History, ADriftWarningSurvivesAKill9) {
  TempDir dir;
  HistoryConfig c;
  c.state_dir = dir.path;
  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    close(fds[0]);
    History h(c, {"x"}, quiet, now);
    for (int i = 0; i < 40; ++i) h.record(move(1.4, 40, i * 1000));
    for (int i = 40; i < 60; ++i) h.record(move(1.4 * 1.2, 40, i * 1000));
    h.flush();
    const char done = h.health("x")["warnings"].empty() ? 'n' : 'y';
    if (write(fds[1], &done, 1) != 1) _exit(1);
    for (;;) pause();  // killed here, the store still open
  }
  close(fds[1]);
  char done = 0;
  ASSERT_EQ(read(fds[0], &done, 1), 1);
  close(fds[0]);
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_EQ(done, 'y');
  History h(c, {"x"}, quiet, now);
  EXPECT_EQ(h.health("x")["warnings"].size(), 1u);
}

TEST(History, QueriesRunOnTheirOwnThreadAndSeeEveryFinishedRecord) {
  // Issue 32: history queries held the daemon's I/O thread; and a GET right
  // after a move could miss its record, still queued for the disk.
  TempDir dir;
  HistoryConfig c;
  c.state_dir = dir.path;
  History h(c, {"x"}, quiet, now);
  for (int i = 0; i < 5; ++i) h.record(move(1.4, 40, i * 1000));
  std::promise<std::pair<std::thread::id, std::size_t>> got;
  HistoryQuery q;
  q.axis = "x";
  ASSERT_TRUE(h.query_async(q, [&](std::vector<MotionRecord> records) {
    got.set_value({std::this_thread::get_id(), records.size()});
  }));
  const auto [thread, n] = got.get_future().get();
  EXPECT_NE(thread, std::this_thread::get_id());
  EXPECT_EQ(n, 5u);
}

}  // namespace
}  // namespace lec6::serve::history
