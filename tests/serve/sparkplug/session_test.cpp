// The Sparkplug B edge node's session (src/serve/sparkplug/session.hpp) on a
// virtual clock: every promise of session.hpp, by the specification's
// assertion ids (docs/sparkplug.md).

#include "sparkplug/session.hpp"

#include <gtest/gtest.h>

#include <set>

namespace lec6::serve::sparkplug {
namespace {

// The test's clock: UTC ms, moved by hand.
struct VirtualClock {
  uint64_t ms = 1'767'950'000'000;
  uint64_t tick(uint64_t d = 100) { return ms += d; }
};

SessionConfig config(std::string host = "") {
  SessionConfig c;
  c.group_id = "plant";
  c.edge_node_id = "box7";
  c.primary_host_id = std::move(host);
  c.node_metrics = {{"Properties/Version", DataType::String, false}};
  for (const char* id : {"axis1", "axis2"}) {
    c.devices.push_back({id,
                         {{"Position mm", DataType::Double, false},
                          {"Flags/BUSY", DataType::Boolean, false},
                          {"Command/Stop", DataType::Boolean, true},
                          {"Command/Run Step", DataType::Int32, true}}});
  }
  return c;
}

std::vector<Value> axis(double mm, bool busy = false) {
  return {mm, busy, false, Value{}};
}

Payload decoded(const Message& m) {
  auto p = decode(m.payload);
  EXPECT_TRUE(p.has_value()) << m.topic;
  return p ? *p : Payload{};
}

const Metric* find(const Payload& p, std::string_view name) {
  for (const Metric& m : p.metrics) {
    if (m.name == name) return &m;
  }
  return nullptr;
}

// A session connected with both devices online: the births already taken.
struct Born {
  VirtualClock clock;
  EdgeSession s{config(), std::nullopt};
  std::vector<Message> births;
  Born() {
    s.node_values({std::string("1.0")}, clock.ms);
    s.device_values(0, true, axis(10), clock.ms);
    s.device_values(1, true, axis(20), clock.ms);
    s.will();
    births = s.connected(clock.tick());
  }
};

// tck-id-message-flow-edge-node-birth-publish-will-message-{topic,qos,will-retained},
// tck-id-topics-ndeath-payload, tck-id-topics-ndeath-seq, tck-id-topics-nbirth-bdseq-increment
TEST(SparkplugSession, WillIsNdeathWithBdSeqOnlyQos1NotRetained) {
  EdgeSession s(config(), std::nullopt);
  const Message w = s.will();
  EXPECT_EQ(w.topic, "spBv1.0/plant/NDEATH/box7");
  EXPECT_EQ(w.qos, 1);
  EXPECT_FALSE(w.retain);
  const Payload p = decoded(w);
  EXPECT_FALSE(p.seq.has_value());
  ASSERT_EQ(p.metrics.size(), 1u);
  EXPECT_EQ(p.metrics[0].name, "bdSeq");
  EXPECT_EQ(p.metrics[0].datatype, DataType::Int64);
  EXPECT_EQ(std::get<int64_t>(p.metrics[0].value), 0);  // starts at zero
}

// tck-id-topics-nbirth-bdseq-increment: +1 per CONNECT, across a restart, 255 -> 0.
TEST(SparkplugSession, BdSeqIncrementsPerConnectAndWraps) {
  EdgeSession s(config(), uint8_t{253});
  std::vector<int64_t> seen;
  for (int i = 0; i < 4; ++i) {
    seen.push_back(std::get<int64_t>(decoded(s.will()).metrics[0].value));
    EXPECT_EQ(s.bdseq(), seen.back());
  }
  EXPECT_EQ(seen, (std::vector<int64_t>{254, 255, 0, 1}));
}

// tck-id-topics-nbirth-seq-num, tck-id-topics-nbirth-bdseq-matching,
// tck-id-operational-behavior-data-commands-rebirth-{name,datatype,value},
// tck-id-payloads-alias-birth-requirement, tck-id-message-flow-device-birth-publish-nbirth-wait
TEST(SparkplugSession, BirthsNbirthThenDbirthsWithNamesAliasesAndValues) {
  Born b;
  ASSERT_EQ(b.births.size(), 3u);
  EXPECT_EQ(b.births[0].topic, "spBv1.0/plant/NBIRTH/box7");
  EXPECT_EQ(b.births[1].topic, "spBv1.0/plant/DBIRTH/box7/axis1");
  EXPECT_EQ(b.births[2].topic, "spBv1.0/plant/DBIRTH/box7/axis2");
  for (const Message& m : b.births) {
    EXPECT_EQ(m.qos, 0);
    EXPECT_FALSE(m.retain);
  }
  const Payload n = decoded(b.births[0]);
  EXPECT_EQ(n.seq, 0u);
  EXPECT_EQ(n.timestamp_ms, b.clock.ms);
  const Metric* bd = find(n, "bdSeq");
  ASSERT_NE(bd, nullptr);
  EXPECT_EQ(std::get<int64_t>(bd->value), b.s.bdseq());
  const Metric* rebirth = find(n, "Node Control/Rebirth");
  ASSERT_NE(rebirth, nullptr);
  EXPECT_EQ(rebirth->datatype, DataType::Boolean);
  EXPECT_EQ(std::get<bool>(rebirth->value), false);
  EXPECT_FALSE(rebirth->alias.has_value());
  EXPECT_EQ(decoded(b.births[1]).seq, 1u);
  EXPECT_EQ(decoded(b.births[2]).seq, 2u);
  const Payload d = decoded(b.births[1]);
  ASSERT_EQ(d.metrics.size(), 4u);
  for (const Metric& m : d.metrics) {
    EXPECT_TRUE(m.name && m.alias && m.datatype && m.timestamp_ms) << *m.name;
  }
  EXPECT_EQ(std::get<double>(find(d, "Position mm")->value), 10.0);
  EXPECT_TRUE(std::holds_alternative<std::monostate>(find(d, "Command/Run Step")->value));
}

// tck-id-payloads-alias-uniqueness
TEST(SparkplugSession, AliasesUniqueAcrossTheNodeAndItsDevices) {
  Born b;
  std::set<uint64_t> aliases;
  std::size_t n = 0;
  for (const Message& m : b.births) {
    for (const Metric& metric : decoded(m).metrics) {
      if (!metric.alias) continue;
      aliases.insert(*metric.alias);
      ++n;
    }
  }
  EXPECT_EQ(aliases.size(), n);
  EXPECT_EQ(n, 1u + 4u + 4u);
}

// tck-id-operational-behavior-data-publish-dbirth-change,
// tck-id-payloads-alias-data-cmd-requirement, tck-id-topics-ddata-seq-num
TEST(SparkplugSession, DdataCarriesOnlyWhatChangedByAlias) {
  Born b;
  EXPECT_TRUE(b.s.device_values(0, true, axis(10), b.clock.tick()).empty());
  EXPECT_TRUE(b.s.node_values({std::string("1.0")}, b.clock.tick()).empty());
  const auto out = b.s.device_values(0, true, axis(12.5), b.clock.tick());
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].topic, "spBv1.0/plant/DDATA/box7/axis1");
  const Payload p = decoded(out[0]);
  EXPECT_EQ(p.seq, 3u);
  ASSERT_EQ(p.metrics.size(), 1u);
  EXPECT_FALSE(p.metrics[0].name.has_value());
  EXPECT_EQ(p.metrics[0].alias, b.s.alias_of(0, 0));
  EXPECT_EQ(std::get<double>(p.metrics[0].value), 12.5);
  EXPECT_EQ(p.metrics[0].timestamp_ms, b.clock.ms);
  const auto nd = b.s.node_values({std::string("1.1")}, b.clock.tick());
  ASSERT_EQ(nd.size(), 1u);
  EXPECT_EQ(nd[0].topic, "spBv1.0/plant/NDATA/box7");
  EXPECT_EQ(decoded(nd[0]).seq, 4u);
}

// tck-id-payloads-sequence-num-incrementing: one counter for all of the node's
// messages, 255 -> 0.
TEST(SparkplugSession, SeqContinuesAcrossMessagesAndWraps) {
  Born b;
  uint64_t expected = 3;
  for (int i = 0; i < 600; ++i) {
    const auto out = b.s.device_values(i % 2, true, axis(1000 + i), b.clock.tick(10));
    ASSERT_EQ(out.size(), 1u);
    EXPECT_EQ(decoded(out[0]).seq, expected % 256) << i;
    ++expected;
  }
}

// tck-id-operational-behavior-device-ddeath, and the DBIRTH when it is back.
TEST(SparkplugSession, DeviceDeathAndRebirth) {
  Born b;
  auto out = b.s.device_values(1, false, axis(20), b.clock.tick());
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].topic, "spBv1.0/plant/DDEATH/box7/axis2");
  EXPECT_EQ(decoded(out[0]).seq, 3u);
  EXPECT_TRUE(b.s.device_values(1, false, axis(21), b.clock.tick()).empty());
  out = b.s.device_values(1, true, axis(22), b.clock.tick());
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].topic, "spBv1.0/plant/DBIRTH/box7/axis2");
  const Payload p = decoded(out[0]);
  EXPECT_EQ(p.seq, 4u);
  EXPECT_EQ(p.metrics.size(), 4u);
  EXPECT_EQ(std::get<double>(find(p, "Position mm")->value), 22.0);
}

// tck-id-operational-behavior-data-commands-rebirth-action-{1,2,3}
TEST(SparkplugSession, RebirthOnNcmdKeepsBdSeq) {
  Born b;
  b.s.device_values(0, true, axis(11), b.clock.tick());
  Payload cmd;
  Metric m;
  m.name = "Node Control/Rebirth";
  m.datatype = DataType::Boolean;
  m.value = true;
  cmd.metrics.push_back(m);
  const auto r = b.s.received("spBv1.0/plant/NCMD/box7", encode(cmd), false, b.clock.tick());
  ASSERT_EQ(r.out.size(), 3u);
  const Payload n = decoded(r.out[0]);
  EXPECT_EQ(r.out[0].topic, "spBv1.0/plant/NBIRTH/box7");
  EXPECT_EQ(n.seq, 0u);
  EXPECT_EQ(std::get<int64_t>(find(n, "bdSeq")->value), 0);
  EXPECT_EQ(decoded(r.out[1]).seq, 1u);
  EXPECT_EQ(std::get<double>(find(decoded(r.out[1]), "Position mm")->value), 11.0);
  // A retained NCMD is not acted on.
  EXPECT_TRUE(
      b.s.received("spBv1.0/plant/NCMD/box7", encode(cmd), true, b.clock.tick()).out.empty());
}

std::string state(bool online, uint64_t ts) {
  return std::string("{\"online\": ") + (online ? "true" : "false") +
         ", \"timestamp\": " + std::to_string(ts) + "}";
}

// tck-id-message-flow-edge-node-birth-publish-phid-wait,
// tck-id-operational-behavior-edge-node-termination-host-offline(-timestamp)
TEST(SparkplugSession, PrimaryHostStateGatesBirthsAndEndsTheSession) {
  VirtualClock clock;
  EdgeSession s(config("scada"), std::nullopt);
  s.device_values(0, true, axis(10), clock.ms);
  const auto subs = s.subscriptions();
  EXPECT_NE(std::find(subs.begin(), subs.end(), "spBv1.0/STATE/scada"), subs.end());
  s.will();
  EXPECT_TRUE(s.connected(clock.tick()).empty());
  EXPECT_TRUE(s.waiting_for_host());
  const std::string topic = "spBv1.0/STATE/scada";
  EXPECT_TRUE(s.received(topic, "garbage", true, clock.tick()).out.empty());
  auto r = s.received(topic, state(true, 1000), true, clock.tick());
  ASSERT_EQ(r.out.size(), 2u);  // NBIRTH, DBIRTH axis1 (axis2 never came online)
  EXPECT_TRUE(s.born());
  // An older offline STATE is ignored.
  r = s.received(topic, state(false, 999), true, clock.tick());
  EXPECT_TRUE(r.out.empty());
  EXPECT_FALSE(r.reconnect);
  // A newer one: NDEATH and reconnect.
  r = s.received(topic, state(false, 2000), true, clock.tick());
  ASSERT_EQ(r.out.size(), 1u);
  EXPECT_EQ(r.out[0].topic, "spBv1.0/plant/NDEATH/box7");
  EXPECT_EQ(std::get<int64_t>(decoded(r.out[0]).metrics[0].value), 0);
  EXPECT_TRUE(r.reconnect);
  // A stop of the daemon now says nothing more: this session died once.
  EXPECT_FALSE(s.goodbye(clock.tick())) << "a second NDEATH for bdSeq 0";
  s.disconnected();
  EXPECT_EQ(std::get<int64_t>(decoded(s.will()).metrics[0].value), 1);
  {
    // The next session's death is its own.
    EdgeSession copy = s;
    const auto bye = copy.goodbye(clock.ms);
    ASSERT_TRUE(bye);
    EXPECT_EQ(std::get<int64_t>(decoded(*bye).metrics[0].value), 1);
  }
  EXPECT_TRUE(s.connected(clock.tick()).empty());
  EXPECT_EQ(s.received(topic, state(true, 3000), true, clock.tick()).out.size(), 2u);
}

// Anyone may publish on the STATE topic: a malformed timestamp is a note,
// never an exception that would end lec serve.
TEST(SparkplugSession, AStateWithAMalformedTimestampIsIgnoredNotThrown) {
  VirtualClock clock;
  EdgeSession s(config("scada"), std::nullopt);
  s.will();
  s.connected(clock.tick());
  const std::string topic = "spBv1.0/STATE/scada";
  for (const char* bad :
       {R"({"online":false,"timestamp":null})", R"({"online":true,"timestamp":"soon"})",
        R"({"online":true,"timestamp":-5})", R"({"online":true,"timestamp":[1]})"}) {
    EdgeSession::Reaction r;
    EXPECT_NO_THROW(r = s.received(topic, bad, true, clock.tick())) << bad;
    EXPECT_TRUE(r.out.empty()) << bad;
    EXPECT_FALSE(r.note.empty()) << bad;
  }
}

Payload dcmd(std::optional<uint64_t> alias, std::optional<std::string> name,
             std::optional<DataType> type, Value v) {
  Payload p;
  Metric m;
  m.alias = alias;
  m.name = std::move(name);
  m.datatype = type;
  m.value = std::move(v);
  p.metrics.push_back(m);
  return p;
}

// tck-id-operational-behavior-data-commands-dcmd-metric-{name,value}: what a host
// may send; anything else refused whole, with the reason.
TEST(SparkplugSession, DcmdResolvedOrRefusedWithAReason) {
  Born b;
  const std::string t = "spBv1.0/plant/DCMD/box7/axis2";
  const uint64_t stop = b.s.alias_of(1, 2);
  auto r = b.s.received(t, encode(dcmd(stop, std::nullopt, DataType::Boolean, true)), false, 0);
  ASSERT_TRUE(r.command);
  EXPECT_EQ(r.command->device, 1u);
  ASSERT_EQ(r.command->writes.size(), 1u);
  EXPECT_EQ(r.command->writes[0].metric, 2u);
  r = b.s.received(t, encode(dcmd(std::nullopt, "Command/Run Step", DataType::Int32, int64_t{3})),
                   false, 0);
  ASSERT_TRUE(r.command);
  EXPECT_EQ(std::get<int64_t>(r.command->writes[0].value), 3);

  auto refused = [&](const Payload& p, std::string_view why, bool retained = false) {
    const auto x = b.s.received(t, encode(p), retained, 0);
    EXPECT_FALSE(x.command);
    ASSERT_TRUE(x.refused);
    EXPECT_NE(x.refused->why.find(why), std::string::npos) << x.refused->why;
  };
  refused(dcmd(9999, std::nullopt, DataType::Boolean, true), "unknown metric alias 9999");
  refused(dcmd(std::nullopt, "Command/Fly", DataType::Boolean, true),
          "unknown metric 'Command/Fly'");
  refused(dcmd(b.s.alias_of(1, 0), std::nullopt, DataType::Double, 5.0), "read-only");
  refused(dcmd(stop, std::nullopt, DataType::String, std::string("yes")), "is Boolean, not String");
  refused(dcmd(stop, std::nullopt, std::nullopt, int64_t{1}), "is Boolean");
  refused(dcmd(stop, std::nullopt, DataType::Boolean, Value{}), "has no value");
  refused(dcmd(stop, std::nullopt, DataType::Boolean, true), "retained", true);
  const auto x = b.s.received(t, "\xff\xff\xff", false, 0);
  ASSERT_TRUE(x.refused);
  // A stop goes whatever else the DCMD holds, a bad metric included.
  Payload both = dcmd(9999, std::nullopt, DataType::Boolean, true);
  both.metrics.push_back(dcmd(stop, std::nullopt, DataType::Boolean, true).metrics[0]);
  const auto y = b.s.received(t, encode(both), false, 0);
  ASSERT_TRUE(y.command) << "the stop fell with the unknown metric beside it";
  ASSERT_EQ(y.command->writes.size(), 1u);
  EXPECT_EQ(y.command->writes[0].metric, 2u);
  // A DCMD for a device the node does not have is ignored.
  EXPECT_FALSE(b.s.received("spBv1.0/plant/DCMD/box7/axis9",
                            encode(dcmd(stop, std::nullopt, DataType::Boolean, true)), false, 0)
                   .command);
}

// A stop is found without the session's owner (stop_request is const and
// reads only what the constructor set), and is taken while the node is not
// born; any other DCMD is refused then.
TEST(SparkplugSession, AStopIsTakenWhenNotBornAndFoundWithoutTheOwner) {
  VirtualClock clock;
  EdgeSession s(config("scada"), std::nullopt);
  s.device_values(1, true, axis(20), clock.ms);
  s.will();
  EXPECT_TRUE(s.connected(clock.tick()).empty());  // waiting for the host
  const std::string t = "spBv1.0/plant/DCMD/box7/axis2";
  const uint64_t stop = s.alias_of(1, 2);
  Payload stop_and_more = dcmd(std::nullopt, "Command/Run Step", DataType::Int32, int64_t{3});
  stop_and_more.metrics.push_back(dcmd(stop, std::nullopt, DataType::Boolean, true).metrics[0]);
  EXPECT_EQ(s.stop_request(t, encode(stop_and_more), false), std::optional<std::size_t>(1));
  EXPECT_EQ(s.stop_request(t, encode(stop_and_more), true), std::nullopt) << "a retained stop";
  EXPECT_EQ(s.stop_request(t, encode(dcmd(stop, std::nullopt, DataType::Boolean, false)), false),
            std::nullopt);
  EXPECT_EQ(s.stop_request("spBv1.0/plant/DCMD/box7/axis9", encode(stop_and_more), false),
            std::nullopt);
  EXPECT_EQ(s.stop_request("spBv1.0/plant/DCMD/box7/axis1", "\xff", false), std::nullopt);
  auto r = s.received(t, encode(stop_and_more), false, clock.tick());
  ASSERT_TRUE(r.command) << "a stop waited for the node's birth";
  r = s.received(t, encode(dcmd(std::nullopt, "Command/Run Step", DataType::Int32, int64_t{3})),
                 false, clock.tick());
  EXPECT_FALSE(r.command) << "a run-step taken before the node was born";
  ASSERT_TRUE(r.refused);
  EXPECT_NE(r.refused->why.find("not born"), std::string::npos) << r.refused->why;
}

// tck-id-operational-behavior-data-commands-rebirth-action-3 with a bdSeq
// other than 0: the rebirth keeps the session's bdSeq, after a reconnect too.
TEST(SparkplugSession, RebirthKeepsTheBdSeqOfTheCurrentConnect) {
  VirtualClock clock;
  EdgeSession s(config(), uint8_t{41});
  s.device_values(0, true, axis(10), clock.ms);
  s.will();
  s.connected(clock.tick());
  s.disconnected();
  s.will();  // reconnect: 43
  ASSERT_EQ(s.connected(clock.tick()).size(), 2u);
  s.device_values(0, true, axis(12), clock.tick());  // seq 1
  const auto again = s.rebirth(clock.tick());
  ASSERT_EQ(again.size(), 2u);
  EXPECT_EQ(decoded(again[0]).seq, 0u);
  EXPECT_EQ(std::get<int64_t>(find(decoded(again[0]), "bdSeq")->value), 43);
  EXPECT_EQ(decoded(again[1]).seq, 1u);
  s.disconnected();
  EXPECT_TRUE(s.rebirth(clock.tick()).empty()) << "births while not connected";
}

TEST(SparkplugPayload, RoundTripsEveryTypeItWrites) {
  Payload p;
  p.timestamp_ms = 1234;
  p.seq = 255;
  auto add = [&](DataType t, Value v) {
    Metric m;
    m.alias = p.metrics.size() + 1;
    m.datatype = t;
    m.value = std::move(v);
    p.metrics.push_back(m);
  };
  add(DataType::Int32, int64_t{-5});
  add(DataType::Int64, int64_t{-1'000'000'000'000});
  add(DataType::Double, 3.25);
  add(DataType::Boolean, true);
  add(DataType::String, std::string("72: drive error"));
  add(DataType::Int32, Value{});
  const auto back = decode(encode(p));
  ASSERT_TRUE(back);
  EXPECT_EQ(back->seq, 255u);
  EXPECT_EQ(back->timestamp_ms, 1234u);
  ASSERT_EQ(back->metrics.size(), p.metrics.size());
  for (std::size_t i = 0; i < p.metrics.size(); ++i) {
    EXPECT_EQ(back->metrics[i].value, p.metrics[i].value) << i;
    EXPECT_EQ(back->metrics[i].alias, p.metrics[i].alias);
  }
  EXPECT_FALSE(decode("\x0a\xff").has_value());
}

}  // namespace
}  // namespace lec6::serve::sparkplug
