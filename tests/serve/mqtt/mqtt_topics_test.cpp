// The MQTT bridge's topic layout, broker URLs and Home Assistant discovery.

#include "lec6/serve/mqtt_topics.hpp"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>

#include "lec6/serve/config.hpp"
#include "mqtt/mqtt_discovery.hpp"

namespace lec6::serve {
namespace {

using nlohmann::json;
using ::testing::HasSubstr;

TEST(MqttTopics, Layout) {
  const MqttTopics t("plant/hall3", "box7");
  EXPECT_EQ(t.status(), "plant/hall3/box7/status");
  EXPECT_EQ(t.state("press", "x"), "plant/hall3/press/x/state");
  EXPECT_EQ(t.availability("press", "x"), "plant/hall3/press/x/availability");
  EXPECT_EQ(t.alarm("press", "x"), "plant/hall3/press/x/alarm");
  EXPECT_EQ(t.cmd("press", "x"), "plant/hall3/press/x/cmd");
  EXPECT_EQ(t.result("press", "x"), "plant/hall3/press/x/result");
}

TEST(MqttTopics, ParseSplitsAxisTopicsOnly) {
  const MqttTopics t("plant/hall3", "box7");
  const auto a = t.parse("plant/hall3/press/x/cmd");
  ASSERT_TRUE(a);
  EXPECT_EQ(a->line, "press");
  EXPECT_EQ(a->axis, "x");
  EXPECT_EQ(a->leaf, "cmd");
  EXPECT_FALSE(t.parse("plant/hall3/box7/status"));  // one level fewer: never an axis
  EXPECT_FALSE(t.parse("plant/hall3/press/x/cmd/extra"));
  EXPECT_FALSE(t.parse("plant/hall3x/press/x/cmd"));
  EXPECT_FALSE(t.parse("plant/hall3/press//cmd"));
  EXPECT_FALSE(t.parse("other/press/x/cmd"));
}

TEST(MqttTopics, PrefixRules) {
  EXPECT_FALSE(check_topic_prefix("lec6"));
  EXPECT_FALSE(check_topic_prefix("plant/hall-3/lec6"));
  EXPECT_THAT(*check_topic_prefix(""), HasSubstr("empty"));
  EXPECT_THAT(*check_topic_prefix("lec6/#"), HasSubstr("wildcard"));
  EXPECT_THAT(*check_topic_prefix("a/+/b"), HasSubstr("wildcard"));
  EXPECT_THAT(*check_topic_prefix("/lec6"), HasSubstr("empty topic level"));
  EXPECT_THAT(*check_topic_prefix("lec6/"), HasSubstr("empty topic level"));
  EXPECT_THAT(*check_topic_prefix("a//b"), HasSubstr("empty topic level"));
  EXPECT_THAT(*check_topic_prefix("$SYS"), HasSubstr("broker"));
}

TEST(BrokerUrl, HostPortAndTls) {
  auto u = parse_broker_url("mqtt://127.0.0.1:1883");
  EXPECT_FALSE(u.tls);
  EXPECT_EQ(u.host, "127.0.0.1");
  EXPECT_EQ(u.port, 1883);
  u = parse_broker_url("mqtts://broker.plant.local");
  EXPECT_TRUE(u.tls);
  EXPECT_EQ(u.host, "broker.plant.local");
  EXPECT_EQ(u.port, 8883);
  u = parse_broker_url("mqtt://[::1]:11883/");
  EXPECT_EQ(u.host, "::1");
  EXPECT_EQ(u.port, 11883);
  EXPECT_EQ(parse_broker_url("mqtt://[fe80::1]").port, 1883);
  for (const char* bad :
       {"tcp://h:1", "mqtt://", "mqtt://h:0", "mqtt://h:70000", "mqtt://h:x", "mqtt://[::1",
        "mqtt://[::1]x", "mqtt://u@h", "mqtt://h/path", "mqtt://h:"}) {
    EXPECT_THROW(parse_broker_url(bad), std::invalid_argument) << bad;
  }
}

std::map<std::string, json> discovery() {
  std::map<std::string, json> out;
  for (auto& p : home_assistant_discovery(MqttTopics("lec6", "box7"), "press", "x", 3)) {
    out[p.topic] = p.payload;
  }
  return out;
}

TEST(HomeAssistant, SensorsBinarySensorsAndButtons) {
  const auto d = discovery();
  const auto& pos = d.at("homeassistant/sensor/lec6_press_x/position_mm/config");
  EXPECT_EQ(pos["state_topic"], "lec6/press/x/state");
  EXPECT_EQ(pos["value_template"], "{{ value_json.position_mm }}");
  EXPECT_EQ(pos["unit_of_measurement"], "mm");
  EXPECT_EQ(d.at("homeassistant/sensor/lec6_press_x/speed_mm_s/config")["unit_of_measurement"],
            "mm/s");
  EXPECT_EQ(d.at("homeassistant/sensor/lec6_press_x/thrust_pct/config")["unit_of_measurement"],
            "%");
  const auto& busy = d.at("homeassistant/binary_sensor/lec6_press_x/busy/config");
  EXPECT_EQ(busy["value_template"], "{{ 'ON' if value_json.flags.busy else 'OFF' }}");
  for (const char* flag : {"inp", "svre", "seton", "alarm", "estop"}) {
    EXPECT_TRUE(d.contains(fmt::format("homeassistant/binary_sensor/lec6_press_x/{}/config", flag)))
        << flag;
  }
  const auto& home = d.at("homeassistant/button/lec6_press_x/home/config");
  EXPECT_EQ(home["command_topic"], "lec6/press/x/cmd");
  // Each press carries a fresh id, else the bridge would answer instead of homing.
  EXPECT_THAT(home["command_template"].get<std::string>(),
              HasSubstr(R"("id": "ha-home-{{ now().timestamp() }}", "op": "home")"));
  EXPECT_TRUE(d.contains("homeassistant/button/lec6_press_x/stop/config"));
  EXPECT_EQ(d.size(), 3u + 6u + 2u);
}

TEST(HomeAssistant, AvailableOnlyWhileTheBridgeAndTheAxisAre) {
  std::set<std::string> ids;
  for (const auto& [topic, p] : discovery()) {
    ASSERT_EQ(p["availability"].size(), 2u) << topic;
    EXPECT_EQ(p["availability"][0]["topic"], "lec6/box7/status");
    EXPECT_EQ(p["availability"][1]["topic"], "lec6/press/x/availability");
    EXPECT_EQ(p["availability_mode"], "all");
    EXPECT_EQ(p["device"]["identifiers"][0], "lec6_press_x");
    EXPECT_TRUE(ids.insert(p["unique_id"].get<std::string>()).second) << "unique ids";
  }
}

TEST(HomeAssistant, IdsStayValidWithASlashedPrefix) {
  for (auto& p : home_assistant_discovery(MqttTopics("plant/hall3", "b"), "press", "x", 1)) {
    EXPECT_THAT(p.topic, ::testing::StartsWith("homeassistant/"));
    EXPECT_EQ(std::count(p.topic.begin(), p.topic.end(), '/'), 4) << p.topic;
    EXPECT_THAT(p.payload["unique_id"].get<std::string>(),
                ::testing::MatchesRegex("[A-Za-z0-9_-]+"));
  }
}

}  // namespace
}  // namespace lec6::serve
