// The config's sparkplug: section (docs/sparkplug.md): defaults, and every
// mistake named by file, line and key before anything runs.

#include <gtest/gtest.h>

#include "lec6/serve/config.hpp"

namespace lec6::serve {
namespace {

const std::string kLines = "lines:\n  - port: sim\n    axes: [{id: 1}, {id: 2, name: lift}]\n";

std::string error_of(const std::string& sparkplug) {
  try {
    parse_config(kLines + sparkplug, "t.yaml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(SparkplugConfig, DefaultsAndEveryKey) {
  EXPECT_FALSE(parse_config(kLines, "t.yaml").sparkplug);
  const auto d = parse_config(kLines + "sparkplug: true\n", "t.yaml").sparkplug;
  ASSERT_TRUE(d);
  EXPECT_EQ(d->broker, "mqtt://127.0.0.1:1883");
  EXPECT_EQ(d->group_id, "lec6");
  EXPECT_TRUE(d->edge_node_id.empty());  // the host name
  EXPECT_TRUE(d->primary_host_id.empty());
  const auto c = parse_config(kLines +
                                  "sparkplug:\n  broker: mqtt://10.0.0.2\n  group_id: plant\n"
                                  "  edge_node_id: box7\n  primary_host_id: scada\n"
                                  "  telemetry_hz: 20\n  keepalive_s: 5\n  bdseq_file: /tmp/x\n"
                                  "  username: u\n  password: p\n",
                              "t.yaml")
                     .sparkplug;
  ASSERT_TRUE(c);
  EXPECT_EQ(c->url().host, "10.0.0.2");
  EXPECT_EQ(c->group_id, "plant");
  EXPECT_EQ(c->edge_node_id, "box7");
  EXPECT_EQ(c->primary_host_id, "scada");
  EXPECT_EQ(c->telemetry_hz, 20);
  EXPECT_EQ(c->keepalive_s, 5u);
  EXPECT_EQ(c->bdseq_file, "/tmp/x");
}

TEST(SparkplugConfig, MistakesNamedByKey) {
  EXPECT_NE(error_of("sparkplug: {group_id: a/b}\n").find("sparkplug.group_id"), std::string::npos);
  EXPECT_NE(error_of("sparkplug: {edge_node_id: \"n#\"}\n").find("one topic level"),
            std::string::npos);
  EXPECT_NE(error_of("sparkplug: {broker: http://x}\n").find("sparkplug.broker"), std::string::npos);
  EXPECT_NE(error_of("sparkplug: {telemetry_hz: 0}\n").find("sparkplug.telemetry_hz"),
            std::string::npos);
  EXPECT_NE(error_of("sparkplug: {password: p}\n").find("needs a username"), std::string::npos);
  EXPECT_NE(error_of("sparkplug: {ca_file: /etc/hostname}\n").find("mqtts://"), std::string::npos);
  EXPECT_NE(error_of("sparkplug: {colour: red}\n").find("colour"), std::string::npos);
}

}  // namespace
}  // namespace lec6::serve
