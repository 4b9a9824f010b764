// Machine cycles inside lec serve (issue 34; src/serve/cycles/): a cycle run
// through the HTTP API on the twin line of a TwinDirectory (fast timing, the
// wall clock), its clients queued on the line's scheduler like any other.
// Requests go straight to HttpApi::handle (no socket); the waits are on
// answers and on polled telemetry with deadlines, never sleeps.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <future>
#include <memory>
#include <thread>

#include "cycles/cycle_service.hpp"
#include "cycles/served_cycle.hpp"
#include "http/api/http_api.hpp"
#include "lec6/client/client.hpp"
#include "line/line_master.hpp"
#include "serve/ops/twin_directory.hpp"

namespace lec6::serve::cycles_test {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using testing::eventually;
using ::testing::HasSubstr;
using testing::TwinDirectory;

// Both axes to the far end, slowly (about 19 s), then x back: a stop comes
// while the parallel group runs.
constexpr const char* kSlowPair = R"(cycle: slow-pair
axes:
  x: 1
  z: 2
steps:
  - parallel:
      - move: {axis: x, to: 390, speed: 20}
      - move: {axis: z, to: 390, speed: 20}
  - move: {axis: x, to: 10}
)";

// A directory of cycle files of the test's own.
class CycleFiles {
 public:
  CycleFiles() {
    dir_ = std::filesystem::temp_directory_path() /
           ("lec6-serve-cycles-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  ~CycleFiles() { std::filesystem::remove_all(dir_); }
  std::filesystem::path write(const std::string& name, const std::string& text) const {
    const auto p = dir_ / name;
    std::ofstream(p) << text;
    return p;
  }
  const std::filesystem::path& dir() const { return dir_; }

 private:
  std::filesystem::path dir_;
};

// The twin line's config with `cycles` read against it, and the API that
// offers them.
struct CycleRig {
  explicit CycleRig(const std::vector<std::filesystem::path>& cycle_files) {
    config.lines = axes.lines();
    for (const auto& f : cycle_files) add_cycles(config, f);
    service = std::make_unique<CycleService>(axes, axes.ops, config.cycles,
                                             [](LogLevel, std::string_view) {});
    api = std::make_unique<HttpApi>(
        axes, axes.ops, http, [](LogLevel, std::string_view) {}, service.get());
    axes.prepare(axes.axis1());
    axes.prepare(axes.axis2());
  }
  ~CycleRig() { axes.stop(); }

  std::future<HttpResponse> send(std::string method, std::string target) {
    HttpRequest r;
    r.method = std::move(method);
    r.target = target;
    const auto split = split_target(target);
    EXPECT_TRUE(split) << target;
    r.path = split->path;
    r.query = split->query;
    r.headers.add("Host", "127.0.0.1:8080");
    r.peer = "127.0.0.1:40000";
    r.loopback_peer = true;
    auto promise = std::make_shared<std::promise<HttpResponse>>();
    auto f = promise->get_future();
    api->handle(std::move(r), Responder::capture([promise](HttpResponse response) {
                  promise->set_value(std::move(response));
                }));
    return f;
  }
  HttpResponse call(std::string method, std::string target) {
    auto f = send(std::move(method), std::move(target));
    EXPECT_EQ(f.wait_for(90s), std::future_status::ready) << target;
    return f.get();
  }
  bool both_moving() const { return axes.moving(axes.axis1()) && axes.moving(axes.axis2()); }
  bool none_moving() const { return !axes.moving(axes.axis1()) && !axes.moving(axes.axis2()); }

  TwinDirectory axes;
  ServeConfig config;
  HttpConfig http;
  std::unique_ptr<CycleService> service;
  std::unique_ptr<HttpApi> api;
};

json body_of(const HttpResponse& r) {
  return json::parse(r.body);
}

std::filesystem::path example(const std::string& name) {
  return std::filesystem::path(LEC6_TEST_DATA_DIR).parent_path().parent_path() / "examples" /
         "cycles" / name;
}

// Every axis of the report's `stood` seen stopped, and there are `n`.
void expect_all_stood_stopped(const json& report, std::size_t n) {
  ASSERT_TRUE(report.contains("stood")) << report.dump(2);
  EXPECT_EQ(report["stood"].size(), n) << report.dump(2);
  for (const auto& s : report["stood"]) {
    EXPECT_TRUE(s.value("stopped", false)) << s.dump();
    EXPECT_TRUE(s["position_mm"].is_number()) << "where it stood: " << s.dump();
  }
}

TEST(ServeCycles, TheExampleCycleRunsToItsEndOnServesSimLine) {
  CycleRig rig({example("pick-place.yaml")});
  const auto list = rig.call("GET", "/api/cycles");
  ASSERT_EQ(list.status, 200) << list.body;
  ASSERT_EQ(body_of(list).size(), 1u) << list.body;
  EXPECT_EQ(body_of(list)[0].value("name", ""), "pick-place");
  EXPECT_EQ(body_of(list)[0]["axes"][1].value("serve_axis", ""), "axis2") << list.body;

  const auto run = rig.call("POST", "/api/cycles/pick-place/run");
  ASSERT_EQ(run.status, 200) << run.body;
  const json report = body_of(run);
  EXPECT_TRUE(report.value("completed", false)) << run.body;
  EXPECT_EQ(report.value("cycle", ""), "pick-place");
  EXPECT_EQ(report.value("passes", 0), 2) << "repeat: 2";
  EXPECT_FALSE(report.value("simulated", true)) << "lec serve runs in real time";
  EXPECT_GE(report["steps"].size(), 16u) << run.body;
  EXPECT_TRUE(report["stood"].empty()) << "nothing stopped";
  ASSERT_EQ(report["analysis"]["lines"].size(), 1u) << "one line: both axes share serve's";

  const auto after = body_of(rig.call("GET", "/api/cycles/pick-place"));
  EXPECT_FALSE(after.value("running", true));
  EXPECT_TRUE(after["last"].value("completed", false)) << after.dump(2);
  // The axes are free again.
  EXPECT_FALSE(rig.axes.ops.running(rig.axes.axis1()));
  EXPECT_FALSE(rig.axes.ops.running(rig.axes.axis2()));
}

TEST(ServeCycles, AnAxisStopPostedDuringAParallelGroupEndsTheCycleWithEveryAxisStopped) {
  CycleFiles files;
  CycleRig rig({files.write("slow-pair.yaml", kSlowPair)});
  auto run = rig.send("POST", "/api/cycles/slow-pair/run");
  ASSERT_TRUE(eventually([&] { return rig.both_moving(); })) << "the parallel group runs";

  const auto stop = rig.call("POST", "/api/axes/axis1/stop");
  EXPECT_EQ(stop.status, 200) << stop.body;
  ASSERT_EQ(run.wait_for(60s), std::future_status::ready);
  const auto ended = run.get();
  EXPECT_EQ(ended.status, 422) << ended.body;
  const json report = body_of(ended);
  EXPECT_FALSE(report.value("completed", true));
  ASSERT_EQ(report["steps"].size(), 1u) << "x's move back never came: " << ended.body;
  EXPECT_EQ(report["steps"][0].value("decision", ""), "stopped") << ended.body;
  for (const auto& a : report["steps"][0]["axes"]) {
    EXPECT_EQ(a.value("outcome", ""), "stopped") << a.dump();
    EXPECT_LT(a.value("position_mm", 400.0), 380.0) << a.dump();
  }
  expect_all_stood_stopped(report, 2);
  EXPECT_TRUE(eventually([&] { return rig.none_moving(); }, 5s)) << "z was stopped too";
  EXPECT_FALSE(rig.axes.ops.running(rig.axes.axis2())) << "its slot is free";
}

TEST(ServeCycles, AHardStopFromAnotherClientOfTheLineEndsTheCycle) {
  CycleFiles files;
  CycleRig rig({files.write("slow-pair.yaml", kSlowPair)});
  auto run = rig.send("POST", "/api/cycles/slow-pair/run");
  ASSERT_TRUE(eventually([&] { return rig.both_moving(); }));

  // As a Modbus TCP client's RESET pulse reaches the line: no operation of
  // lec serve's knows of it, only the line's scheduler.
  LineMaster plc(rig.axes.line1(), Priority::Command, Priority::Command);
  client::ClientOptions co;
  co.id = 2;
  client::Client c(plc, co);
  c.write_coil(lec::Coil::RESET, true);
  c.write_coil(lec::Coil::RESET, false);

  ASSERT_EQ(run.wait_for(60s), std::future_status::ready);
  const auto ended = run.get();
  EXPECT_EQ(ended.status, 422) << ended.body;
  expect_all_stood_stopped(body_of(ended), 2);
  EXPECT_TRUE(eventually([&] { return rig.none_moving(); }, 5s));
}

TEST(ServeCycles, ASecondRunWhileOneRunsIs409AndTheCyclesStopEndsIt) {
  CycleFiles files;
  CycleRig rig({files.write("slow-pair.yaml", kSlowPair)});
  const auto first = rig.call("POST", "/api/cycles/slow-pair/run?wait=false");
  ASSERT_EQ(first.status, 202) << first.body;
  ASSERT_TRUE(eventually([&] { return rig.both_moving(); }));

  const auto second = rig.call("POST", "/api/cycles/slow-pair/run");
  EXPECT_EQ(second.status, 409) << second.body;
  EXPECT_THAT(body_of(second).value("error", ""), HasSubstr("cycle slow-pair is running"));
  // Its axes' motion slots are the cycle's.
  const auto move = rig.axes.run(rig.axes.axis2(), "move", {{"position_mm", 10}});
  EXPECT_EQ(move.status, 409) << move.body.dump();
  EXPECT_THAT(move.body.value("error", ""), HasSubstr("busy: cycle slow-pair"));
  EXPECT_TRUE(body_of(rig.call("GET", "/api/cycles/slow-pair")).value("running", false));

  const auto stop = rig.call("POST", "/api/cycles/slow-pair/stop");
  EXPECT_EQ(stop.status, 200) << stop.body;
  const json report = body_of(stop);
  EXPECT_FALSE(report.value("completed", true));
  expect_all_stood_stopped(report, 2);
  EXPECT_EQ(report["stops"].size(), 2u) << stop.body;
  EXPECT_FALSE(body_of(rig.call("GET", "/api/cycles/slow-pair")).value("running", true));
  EXPECT_EQ(rig.call("POST", "/api/cycles/slow-pair/stop").status, 409) << "not running";
}

// lec serve shutting down during a cycle (SIGTERM): the lines take only
// stops, and the exchange the cycle had under way fails with "shutting
// down". That is the stop ending the cycle, not a line fault: every axis is
// stopped and read at Emergency (which the stopping line still takes), and
// the report says where each stood. (A reviewer's finding: the report said
// "line fault" and had no positions.)
TEST(ServeCycles, AShutdownDuringACycleStopsEveryAxisAndTheReportSaysWhereEachStood) {
  // Both orders: the daemon's (the line, then the operations, back to back)
  // and the line's stopping alone (the operations told after the cycle has
  // ended: Line::stopping is what ends it then).
  for (const bool daemon_order : {true, false}) {
    SCOPED_TRACE(daemon_order ? "line then operations" : "the line alone");
    CycleFiles files;
    CycleRig rig({files.write("slow-pair.yaml", kSlowPair)});
    auto run = rig.send("POST", "/api/cycles/slow-pair/run");
    ASSERT_TRUE(eventually([&] { return rig.both_moving(); })) << "the parallel group runs";

    rig.axes.line1().begin_stop();
    if (daemon_order) rig.axes.ops.begin_shutdown();
    ASSERT_EQ(run.wait_for(60s), std::future_status::ready);
    if (!daemon_order) rig.axes.ops.begin_shutdown();
    const auto ended = run.get();
    EXPECT_EQ(ended.status, 422) << ended.body;
    const json report = body_of(ended);
    EXPECT_THAT(report.value("ended", ""), ::testing::StartsWith("stopped by request"))
        << ended.body;
    ASSERT_EQ(report["steps"].size(), 1u) << ended.body;
    EXPECT_EQ(report["steps"][0].value("decision", ""), "stopped") << ended.body;
    expect_all_stood_stopped(report, 2);
    for (const auto& s : report["stood"])
      EXPECT_LT(s.value("position_mm", 400.0), 380.0) << s.dump();
  }
}

// Operations::run_claimed answers a refusal after letting its lock go: the
// answer may ask the operations again (a front-end reading the axis's
// state for its reply). Before, the 503 of a shutdown was answered under
// the lock, and such an answer deadlocked.
TEST(ServeCycles, ARefusedClaimIsAnsweredOutsideTheOperationsLock) {
  TwinDirectory axes;
  axes.ops.begin_shutdown();
  auto answered = std::make_shared<std::promise<int>>();
  auto f = answered->get_future();
  std::thread([&axes, answered] {
    axes.ops.run_claimed(
        {axes.axis1()}, "cycle test", "test",
        [](const Operations::Claim&) {
          return OpResult{200, json::object()};
        },
        [&axes, answered](OpResult r) {
          (void)axes.ops.running(axes.axis1());  // takes the operations' lock
          answered->set_value(r.status);
        });
  }).detach();
  ASSERT_EQ(f.wait_for(10s), std::future_status::ready) << "the answer deadlocked";
  EXPECT_EQ(f.get(), 503);
}

TEST(ServeCycles, AnUnknownCycleIs404) {
  CycleFiles files;
  CycleRig rig({files.write("slow-pair.yaml", kSlowPair)});
  const auto r = rig.call("POST", "/api/cycles/nope/run");
  EXPECT_EQ(r.status, 404) << r.body;
  EXPECT_THAT(body_of(r).value("error", ""), HasSubstr("no cycle called 'nope'"));
  EXPECT_EQ(rig.call("GET", "/api/cycles/nope").status, 404);
  EXPECT_EQ(rig.call("GET", "/api/cycles/slow-pair/run").status, 405);
}

TEST(ServeCycles, ACycleNamingAnAxisServeDoesNotHaveIsRefusedAtLoad) {
  CycleFiles files;
  const auto good = files.write("a-good.yaml", kSlowPair);
  const auto bad = files.write("b-bad.yaml", R"(cycle: far
axes:
  x: 1
  y: 5
steps:
  - move: {axis: y, to: 10}
)");
  TwinDirectory axes;
  ServeConfig config;
  config.lines = axes.lines();
  try {
    add_cycles(config, files.dir());
    FAIL() << "loaded";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr(bad.string() + ":4:"));
    EXPECT_THAT(e.what(), HasSubstr("axes.y: lec serve has no axis with ID 5 on line line1"));
    EXPECT_THAT(e.what(), HasSubstr("axis1 (ID 1), axis2 (ID 2)"));
  }
  EXPECT_TRUE(config.cycles.empty()) << "nothing half-applied: the good file is not kept either";

  // In the config file: its line named too, and no config at all.
  const std::string text = fmt::format(
      "lines:\n  - port: sim\n    axes: [{{id: 1}}, {{id: 2}}]\ncycles:\n  - {}\n  - {}\n",
      good.string(), bad.string());
  try {
    parse_config(text, (files.dir() / "lec6.yaml").string());
    FAIL() << "parsed";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("lec6.yaml:6: cycles[1]: "));
    EXPECT_THAT(e.what(), HasSubstr("axes.y: lec serve has no axis with ID 5"));
  }
  const auto ok =
      parse_config("lines:\n  - port: sim\n    axes: [{id: 1}, {id: 2}]\ncycles: a-good.yaml\n",
                   (files.dir() / "lec6.yaml").string());
  ASSERT_EQ(ok.cycles.size(), 1u) << "relative to the config file";
}

}  // namespace
}  // namespace lec6::serve::cycles_test
