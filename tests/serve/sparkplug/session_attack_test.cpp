// Attacks on the sans-I/O Sparkplug session's promises (session.hpp,
// docs/sparkplug.md) from a review: the one stop rule against payloads a
// careless host may send, and NDEATH once per session.

#include <gtest/gtest.h>

#include "sparkplug/session.hpp"

namespace lec6::serve::sparkplug {
namespace session_attack {

SessionConfig attack_config(std::string host = "") {
  SessionConfig c;
  c.group_id = "plant";
  c.edge_node_id = "box7";
  c.primary_host_id = std::move(host);
  c.node_metrics = {{"Properties/Version", DataType::String, false}};
  for (const char* id : {"axis1", "axis2"}) {
    c.devices.push_back({id,
                         {{"Position mm", DataType::Double, false},
                          {"Command/Stop", DataType::Boolean, true},
                          {"Command/Home", DataType::Boolean, true}}});
  }
  return c;
}

Metric stop_metric(const EdgeSession& s) {
  Metric m;
  m.alias = s.alias_of(0, 1);  // axis1's Command/Stop
  m.datatype = DataType::Boolean;
  m.value = true;
  return m;
}

// A protobuf field: key and length-delimited bytes.
std::string length_delimited(int field, const std::string& bytes) {
  std::string out;
  uint64_t key = (static_cast<uint64_t>(field) << 3) | 2;
  while (key >= 0x80) {
    out += static_cast<char>((key & 0x7f) | 0x80);
    key >>= 7;
  }
  out += static_cast<char>(key);
  out += static_cast<char>(bytes.size());  // short fields only
  return out + bytes;
}

const std::string kTopic = "spBv1.0/plant/DCMD/box7/axis1";

// Siblings the node does not know, but that are well-formed protobuf, leave the
// stop alone: a DataSet value (field 17 of Metric, not in lec6's .proto), a name
// that is not UTF-8, a metric with neither name nor alias. (These hold.)
TEST(SparkplugSessionAttack, AStopIsFoundBesideSiblingsTheNodeDoesNotKnow) {
  EdgeSession s(attack_config(), std::nullopt);
  Payload p;
  p.metrics.push_back(stop_metric(s));
  const std::string stop_only = encode(p);
  const std::string dataset_sibling =
      length_delimited(2, length_delimited(1, "Table") + length_delimited(17, "\x08\x01"));
  const std::string not_utf8_sibling = length_delimited(2, length_delimited(1, "\xff\xfe"));
  const std::string empty_sibling = length_delimited(2, "");
  for (const std::string& sibling : {dataset_sibling, not_utf8_sibling, empty_sibling}) {
    EXPECT_EQ(s.stop_request(kTopic, stop_only + sibling, false), 0u);
    EXPECT_EQ(s.stop_request(kTopic, sibling + stop_only, false), 0u);
  }
}

// session.hpp: "A stop (Command/Stop = true) goes whatever else the DCMD holds";
// session.cpp: "a stop never waits for, nor falls with, anything else". A
// sibling metric that is not well-formed protobuf (a truncated property set: a
// host's encoder bug, a corrupted write) makes the whole payload fail to parse,
// and the stop beside it falls with it: not found by stop_request(), and the
// DCMD refused as "not a Sparkplug B payload" (each metric is now parsed on
// its own: visit_metrics_leniently).
TEST(SparkplugSessionAttack, AStopIsNotLostWithAMalformedSiblingMetric) {
  EdgeSession s(attack_config(), std::nullopt);
  Payload p;
  p.metrics.push_back(stop_metric(s));
  const std::string stop_only = encode(p);
  // Metric { name: "Command/Home", properties: <5 bytes announced, 1 there> }
  const std::string truncated_properties = std::string("\x4a\x05\x01", 3);
  const std::string bad_sibling =
      length_delimited(2, length_delimited(1, "Command/Home") + truncated_properties);
  ASSERT_TRUE(s.stop_request(kTopic, stop_only, false));
  EXPECT_EQ(s.stop_request(kTopic, stop_only + bad_sibling, false), std::optional<std::size_t>(0))
      << "the stop fell with a malformed sibling";
  EXPECT_EQ(s.stop_request(kTopic, bad_sibling + stop_only, false), std::optional<std::size_t>(0))
      << "the stop fell with a malformed sibling before it";
  // And the session's own path (the node not born: only a stop is taken) must
  // not refuse it either.
  s.will();
  auto r = s.received(kTopic, stop_only + bad_sibling, false, 1000);
  EXPECT_TRUE(r.command.has_value()) << (r.refused ? r.refused->why : r.note);
}

// NDEATH exactly once per session: the primary host's offline STATE made the
// session publish its NDEATH (bdSeq 0) and drop the connection; a clean stop
// (SIGTERM) before that DISCONNECT went out (the client waits up to 2 s for the
// NDEATH's PUBACK first) asks goodbye() for the NDEATH again and gets a second
// one for the same bdSeq, which Core::stop() publishes while the client is
// still connected. A host sees the session die twice (goodbye() now says
// nothing the second time).
TEST(SparkplugSessionAttack, NdeathOncePerSessionWhenAStopFollowsTheHostsOffline) {
  EdgeSession s(attack_config("scada"), std::nullopt);
  s.will();
  EXPECT_TRUE(s.connected(1000).empty());
  const std::string state_topic = "spBv1.0/STATE/scada";
  EXPECT_FALSE(
      s.received(state_topic, R"({"online":true,"timestamp":10})", true, 1001).out.empty());
  ASSERT_TRUE(s.born());
  auto r = s.received(state_topic, R"({"online":false,"timestamp":20})", true, 1002);
  ASSERT_EQ(r.out.size(), 1u);
  ASSERT_EQ(r.out[0].topic, "spBv1.0/plant/NDEATH/box7");
  ASSERT_TRUE(r.reconnect);
  const auto again = s.goodbye(1003);  // SIGTERM before the DISCONNECT
  EXPECT_FALSE(again) << "a second NDEATH for bdSeq " << int{s.bdseq()};
}

}  // namespace session_attack
}  // namespace lec6::serve::sparkplug
