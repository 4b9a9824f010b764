#pragma once
// An AxisDirectory of its own for the front-ends' tests: one line on the
// built-in twin (fast timing), axis1 (id 1) and axis2 (id 2), and the
// Operations that run their commands. No daemon, no listener, no socket: a
// test hands it to HttpApi or MqttBridge as the daemon would.
//
// The wall clock: operations block on their line's answers on threads of
// their own, so the line runs on its thread; the waits are on results and on
// polled state with deadlines, never sleeps to synchronise.

#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "line/line.hpp"
#include "line/wire.hpp"
#include "ops/axis_directory.hpp"
#include "ops/commands.hpp"
#include "ops/operations.hpp"

namespace lec6::serve::testing {

// Polls `done` until it holds or `within` passes.
inline bool eventually(const std::function<bool()>& done,
                       std::chrono::milliseconds within = std::chrono::seconds(20)) {
  const auto end = std::chrono::steady_clock::now() + within;
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

class TwinDirectory final : public AxisDirectory {
 public:
  TwinDirectory() {
    LineConfig lc;
    lc.name = "line1";
    lc.port = "sim";
    lc.sim.fast = true;
    lc.probe_interval_ms = 200;
    for (uint8_t id : {1, 2}) {
      AxisConfig a;
      a.id = id;
      a.name = "axis" + std::to_string(id);
      a.telemetry_hz = 20;
      lc.axes.push_back(a);
    }
    lines_.push_back(lc);
    LineOptions o;
    o.name = lc.name;
    o.port = lc.port;
    o.scheduler = scheduler_config(lc);
    line_ = std::make_unique<Line>(
        o, [this] { return open_wire(lines_[0]); }, clock_);
    line_->start();
    for (const AxisConfig& a : lines_[0].axes) {
      axes_.push_back(AxisRef{a.name, a.id, line_.get(), &lines_[0], &a});
    }
    ops.add_observer([this](const std::string& axis, const nlohmann::json& event) {
      std::lock_guard lock(events_mutex_);
      events_.push_back({axis, event});
    });
  }
  ~TwinDirectory() override { stop(); }
  // As the daemon stops: jogs released while the line still runs, then the
  // line, then the operations' threads. A front-end given this directory
  // must not go before this ran (its observers are called until then).
  void stop() {
    ops.shutdown();
    line_->stop();
    ops.shutdown();
  }
  TwinDirectory(const TwinDirectory&) = delete;
  TwinDirectory& operator=(const TwinDirectory&) = delete;

  const std::vector<AxisRef>& axes() const override { return axes_; }
  const std::vector<LineConfig>& lines() const override { return lines_; }
  Line* line(std::string_view name) const override {
    return name == lines_[0].name ? line_.get() : nullptr;
  }
  history::History* history() const override { return nullptr; }

  Line& line1() { return *line_; }
  const AxisRef& axis1() const { return axes_[0]; }
  const AxisRef& axis2() const { return axes_[1]; }

  // Runs `op` on `axis` through the operations and waits for its result.
  OpResult run(const AxisRef& axis, std::string_view op,
               nlohmann::json args = nlohmann::json::object()) {
    auto done = start(axis, op, std::move(args));
    EXPECT_EQ(done.wait_for(std::chrono::seconds(60)), std::future_status::ready) << op;
    return done.get();
  }
  std::future<OpResult> start(const AxisRef& axis, std::string_view op, nlohmann::json args,
                              std::string source = "test") {
    auto cmd = parse_command(op, args);
    EXPECT_TRUE(cmd) << op << ": " << (cmd ? "" : cmd.error().message);
    auto promise = std::make_shared<std::promise<OpResult>>();
    auto f = promise->get_future();
    ops.run(axis, *cmd, std::move(source),
            [promise](OpResult r) { promise->set_value(std::move(r)); });
    return f;
  }
  // Serial on, servo on, homed: ready for moves. Its operations are left
  // out of events() (a test counts its own).
  void prepare(const AxisRef& axis) {
    ASSERT_EQ(run(axis, "serial", {{"on", true}}).status, 200);
    ASSERT_EQ(run(axis, "servo", {{"on", true}}).status, 200);
    ASSERT_EQ(run(axis, "home").status, 200);
    std::lock_guard lock(events_mutex_);
    events_.clear();
  }
  // Whether the twin's axis is moving, from the line's telemetry.
  bool moving(const AxisRef& axis) const {
    const auto s = line_->snapshot(axis.id);
    return s.state && s.state->speed_mm_s > 0;
  }

  // Every operation event ("started", "finished"), as the observers get them.
  struct Event {
    std::string axis;
    nlohmann::json body;
  };
  std::vector<Event> events() const {
    std::lock_guard lock(events_mutex_);
    return events_;
  }
  // How many `op`s started on `axis`.
  std::size_t started(const std::string& axis, std::string_view op) const {
    std::size_t n = 0;
    for (const Event& e : events()) {
      n += e.axis == axis && e.body.value("event", "") == "started" && e.body.value("op", "") == op;
    }
    return n;
  }

 private:
  SteadyClock clock_;
  std::vector<LineConfig> lines_;
  std::unique_ptr<Line> line_;
  std::vector<AxisRef> axes_;
  mutable std::mutex events_mutex_;
  std::vector<Event> events_;

 public:
  Operations ops{[](LogLevel, std::string_view) {}};
};

}  // namespace lec6::serve::testing
