// The MQTT bridge over an AxisDirectory of its own (a twin line, no daemon)
// and a fake session in place of the broker: the test hands the bridge
// command messages as the broker would and reads what it published.

#include "mqtt/mqtt_bridge.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <asio/io_context.hpp>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "lec6/serve/mqtt_topics.hpp"
#include "serve/ops/twin_directory.hpp"

namespace lec6::serve {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using testing::eventually;
using testing::TwinDirectory;

// What the fake broker saw, and the bridge's handlers to deliver to.
struct FakeBroker {
  std::mutex mutex;
  std::vector<std::pair<std::string, std::string>> published;  // topic, payload
  MqttClientHandlers handlers;

  std::vector<json> on(const std::string& topic) {
    std::lock_guard lock(mutex);
    std::vector<json> out;
    for (const auto& [t, p] : published) {
      if (t == topic) out.push_back(json::parse(p));
    }
    return out;
  }
  // The results published for command `id`.
  std::vector<json> results(const std::string& topic, const std::string& id) {
    std::vector<json> out;
    for (const json& r : on(topic)) {
      if (r.value("id", "") == id) out.push_back(r);
    }
    return out;
  }
};

class FakeSession final : public MqttSession {
 public:
  explicit FakeSession(std::shared_ptr<FakeBroker> broker) : broker_(std::move(broker)) {}
  void start() override {}
  bool publish(const std::string& topic, std::string_view payload, int, bool,
               const ReplyTo*) override {
    std::lock_guard lock(broker_->mutex);
    broker_->published.emplace_back(topic, std::string(payload));
    return true;
  }
  void subscribe(const std::vector<std::string>&) override {}
  void stop(const std::vector<std::pair<std::string, std::string>>&, Duration) override {}
  bool connected() const override { return true; }

 private:
  std::shared_ptr<FakeBroker> broker_;
};

struct BridgeRig {
  BridgeRig() {
    config.prefix = "lec6";
    config.bridge = "box";
    bridge = std::make_unique<MqttBridge>(
        io, axes, axes.ops, config, [](LogLevel, std::string_view) {},
        [b = broker](MqttClientOptions, MqttClientHandlers h) {
          b->handlers = std::move(h);
          return std::make_unique<FakeSession>(b);
        });
    bridge->start();
  }
  ~BridgeRig() {
    bridge->stop();
    axes.stop();
  }

  // A command on axis1's cmd topic, as the broker delivers it.
  void command(const json& payload) {
    MqttMessage m;
    m.topic = topics.cmd("line1", "axis1");
    m.payload = payload.dump();
    broker->handlers.message(m);
  }
  std::vector<json> results(const std::string& id) {
    return broker->results(topics.result("line1", "axis1"), id);
  }

  asio::io_context io;  // the bridge's timers; never run here
  TwinDirectory axes;
  MqttConfig config;
  MqttTopics topics{"lec6", "box"};
  std::shared_ptr<FakeBroker> broker = std::make_shared<FakeBroker>();
  std::unique_ptr<MqttBridge> bridge;
};

TEST(MqttBridge, ACommandDeliveredTwiceRunsOnceAndTheRepeatGetsTheSameResult) {
  BridgeRig rig;
  rig.axes.prepare(rig.axes.axis1());
  const json move{{"id", "m1"}, {"op", "move"}, {"position_mm", 100}, {"speed_mm_s", 200}};
  rig.command(move);
  rig.command(move);  // QoS 1 redelivery while it runs: nothing more
  ASSERT_TRUE(eventually([&] { return !rig.results("m1").empty(); }));
  rig.command(move);  // a client's retry after it ended: the same result again
  ASSERT_TRUE(eventually([&] { return rig.results("m1").size() == 2; }));

  const auto results = rig.results("m1");
  EXPECT_EQ(results[0]["status"], 200) << results[0].dump();
  EXPECT_EQ(results[1], results[0]);
  EXPECT_EQ(rig.axes.started("axis1", "move"), 1u) << "the move ran more than once";

  // Another id is another command.
  rig.command({{"id", "m2"}, {"op", "move"}, {"position_mm", 50}, {"speed_mm_s", 200}});
  ASSERT_TRUE(eventually([&] { return !rig.results("m2").empty(); }));
  EXPECT_EQ(rig.axes.started("axis1", "move"), 2u);
}

TEST(MqttBridge, AStopIsAcceptedWhileTheAxisIsBusy) {
  BridgeRig rig;
  rig.axes.prepare(rig.axes.axis1());
  rig.command({{"id", "m1"}, {"op", "move"}, {"position_mm", 390}, {"speed_mm_s", 20}});
  ASSERT_TRUE(eventually([&] { return rig.axes.moving(rig.axes.axis1()); }));
  // A second motion is refused: the axis is busy.
  rig.command({{"id", "m2"}, {"op", "move"}, {"position_mm", 10}});
  ASSERT_TRUE(eventually([&] { return !rig.results("m2").empty(); }));
  EXPECT_EQ(rig.results("m2")[0]["status"], 409) << rig.results("m2")[0].dump();

  rig.command({{"id", "s1"}, {"op", "stop"}});
  ASSERT_TRUE(eventually([&] { return !rig.results("s1").empty(); }));
  EXPECT_EQ(rig.results("s1")[0]["status"], 200) << rig.results("s1")[0].dump();
  ASSERT_TRUE(eventually([&] { return !rig.results("m1").empty(); }));
  const json moved = rig.results("m1")[0];
  EXPECT_EQ(moved["status"], 422) << moved.dump();
  EXPECT_EQ(moved.value("outcome", ""), "stopped") << moved.dump();
}

TEST(MqttBridge, ABadCommandIsRefusedNamingTheFieldAndNothingRuns) {
  BridgeRig rig;
  rig.command({{"id", "b1"}, {"op", "move"}, {"position_mm", 10}, {"speed_mm_s", 70000}});
  ASSERT_TRUE(eventually([&] { return !rig.results("b1").empty(); }));
  const json r = rig.results("b1")[0];
  EXPECT_EQ(r["status"], 400) << r.dump();
  EXPECT_EQ(r.value("field", ""), "speed_mm_s") << r.dump();
  EXPECT_TRUE(rig.axes.events().empty());
}

}  // namespace
}  // namespace lec6::serve
