// A clean stop never fires the will (issue 35): MqttClient::stop() while
// messages stream in to the client and its own QoS 1 publish awaits a PUBACK,
// while QoS 1 messages are queued for it, while the broker is stalled; and a
// reconnect() with the broker stalled says its last QoS 1 message once (the
// last three: a reviewer's attacks, each failed before disconnect_now()
// lingered).
// The will is what the broker says for a lost client; a Sparkplug node whose
// will is its NDEATH would say it twice for one bdSeq. libmosquitto 2 marks
// the connection disconnected when a DISCONNECT is queued, and a packet read
// before it is written closes the socket without it: the DISCONNECT must be
// queued and written on the loop's thread with no read between. Real
// mosquitto on loopback; a checker and a flooder of plain libmosquitto.

#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <mosquitto.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <thread>

#include "mqtt/mqtt_client.hpp"

extern char** environ;

namespace lec6::serve::will_test {
namespace {

using namespace std::chrono_literals;

uint16_t free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(fd);
  return ntohs(a.sin_port);
}

bool listening(uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(port);
  const bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  ::close(fd);
  return ok;
}

// Polls `pred` until it holds or `limit` passes (real I/O: the broker).
bool wait_for(const std::function<bool()>& pred, std::chrono::milliseconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(2ms);
  }
  return true;
}

struct Broker {
  uint16_t port = free_port();
  pid_t pid = -1;
  std::filesystem::path dir;

  explicit Broker(const std::string& extra = {}) {
    char tmpl[] = "/tmp/lec6-will-XXXXXX";
    dir = ::mkdtemp(tmpl);
    const auto conf = dir / "mosquitto.conf";
    std::ofstream(conf) << (::geteuid() == 0 ? "user root\n" : "") << "listener " << port
                        << " 127.0.0.1\nallow_anonymous true\npersistence false\n"
                        << extra;
    const std::string log = (dir / "mosquitto.log").string();
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    std::string c = conf.string();
    char* argv[] = {const_cast<char*>("mosquitto"), const_cast<char*>("-c"), c.data(), nullptr};
    const int rc = posix_spawnp(&pid, "mosquitto", &fa, nullptr, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) pid = -1;
  }
  ~Broker() {
    if (pid > 0) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, nullptr, 0);
    }
    std::error_code ec;
    if (!std::getenv("KEEP")) std::filesystem::remove_all(dir, ec);
  }
};

// A plain libmosquitto client with its own loop thread.
struct Peer {
  mosquitto* m = nullptr;
  std::atomic<int> wills{0};   // "died …" on t/will: a client's will
  std::atomic<int> probes{0};  // the checker's own probe
  std::atomic<int> lasts{0};   // on t/last: a client's last words
  std::atomic<bool> connected{false};

  explicit Peer(const char* id) {
    mosquitto_lib_init();  // counted: once per Peer is fine
    m = mosquitto_new(id, true, this);
    mosquitto_connect_callback_set(m, [](mosquitto*, void* self, int rc) {
      if (rc == 0) static_cast<Peer*>(self)->connected = true;
    });
    mosquitto_message_callback_set(m, [](mosquitto*, void* self, const mosquitto_message* msg) {
      const std::string text(static_cast<const char*>(msg->payload),
                             static_cast<std::size_t>(msg->payloadlen));
      auto* p = static_cast<Peer*>(self);
      ++(std::string(msg->topic) == "t/last" ? p->lasts
         : text.starts_with("died")          ? p->wills
                                             : p->probes);
    });
  }
  bool start(uint16_t port) {
    return mosquitto_connect(m, "127.0.0.1", port, 30) == MOSQ_ERR_SUCCESS &&
           mosquitto_loop_start(m) == MOSQ_ERR_SUCCESS &&
           wait_for([this] { return connected.load(); }, 5s);
  }
  ~Peer() {
    mosquitto_disconnect(m);
    mosquitto_loop_stop(m, false);
    mosquitto_destroy(m);
  }
};

// A checker subscribed to t/# whose subscription is in place: it heard its own probe.
bool start_checker(Peer& checker, uint16_t port) {
  int mid = 0;
  return checker.start(port) &&
         mosquitto_subscribe(checker.m, &mid, "t/#", 1) == MOSQ_ERR_SUCCESS &&
         wait_for(
             [&] {
               mosquitto_publish(checker.m, nullptr, "t/will", 5, "probe", 1, false);
               return wait_for([&] { return checker.probes.load() > 0; }, 100ms);
             },
             5s);
}

// Each socket the broker saw closed without a DISCONNECT, in its words.
std::string unclean_lines(const Broker& broker) {
  std::string unclean;
  std::ifstream log(broker.dir / "mosquitto.log");
  for (std::string line; std::getline(log, line);)
    if (line.find("closed its connection") != std::string::npos ||
        line.find("disconnected:") != std::string::npos ||
        line.find("disconnected,") != std::string::npos)
      unclean += "\n  " + line;
  return unclean;
}

// A broker and a checker subscribed to t/#, both up (up() says what is not).
struct Plant {
  Broker broker;
  Peer checker;
  explicit Plant(const char* checker_id, const std::string& extra = {})
      : broker(extra), checker(checker_id) {}
  ::testing::AssertionResult up() {
    if (broker.pid <= 0)
      return ::testing::AssertionFailure() << "cannot start mosquitto (tools/deps.txt lists it)";
    if (!wait_for([&] { return listening(broker.port); }, 10s))
      return ::testing::AssertionFailure() << "mosquitto not listening";
    if (!start_checker(checker, broker.port))
      return ::testing::AssertionFailure() << "the checker did not hear its own probe";
    return ::testing::AssertionSuccess();
  }
};

MqttClientOptions options(const Broker& broker, const std::string& id) {
  MqttClientOptions o;
  o.url = BrokerUrl{false, "127.0.0.1", broker.port};
  o.client_id = id;
  o.will_topic = "t/will";
  o.will_payload = "died " + id;
  o.will_retain = false;
  o.last_retain = false;
  return o;
}

TEST(MqttClientWill, AStopWhileMessagesStreamInNeverFiresTheWill) {
  Plant p("will-checker");
  ASSERT_TRUE(p.up());

  // The flooder keeps the client's socket readable: a packet is there to be
  // read at any instant the DISCONNECT could be queued.
  Peer flooder("will-flooder");
  ASSERT_TRUE(flooder.start(p.broker.port));
  std::atomic<bool> flooding{true};
  std::thread flood([&] {
    const std::string payload(64, 'x');
    while (flooding) {
      mosquitto_publish(flooder.m, nullptr, "in/x", static_cast<int>(payload.size()),
                        payload.data(), 0, false);
      std::this_thread::sleep_for(200us);
    }
  });

  constexpr int kRounds = 30;
  int connected_rounds = 0;
  for (int i = 0; i < kRounds; ++i) {
    MqttClientOptions o;
    o.url = BrokerUrl{false, "127.0.0.1", p.broker.port};
    o.client_id = "will-client-" + std::to_string(i);
    o.will_topic = "t/will";
    o.will_payload = "died " + std::to_string(i);
    o.will_retain = false;
    o.last_retain = false;
    std::atomic<bool> up{false};
    MqttClientHandlers h;
    h.connected = [&up] { up = true; };
    h.message = [](const MqttMessage&) {};
    MqttClient client(o, h);
    client.start();
    if (!wait_for([&] { return up.load(); }, 5s)) continue;
    ++connected_rounds;
    client.subscribe({"in/#"});
    // Messages arriving, and a QoS 1 publish whose PUBACK comes any moment.
    wait_for([&] { return client.stats().received > 5; }, 2s);
    client.publish("t/out", "last words", 1, false);
    client.stop({}, 2s);
  }
  flooding = false;
  flood.join();
  // A will is published the moment the broker sees the socket close; give
  // the checker's delivery a bounded wait for the last one.
  wait_for([&] { return p.checker.wills.load() > 0; }, 500ms);
  EXPECT_EQ(connected_rounds, kRounds);
  EXPECT_EQ(p.checker.wills.load(), 0)
      << "a clean stop fired the will " << p.checker.wills.load() << " times in " << kRounds
      << " rounds; the broker said:" << unclean_lines(p.broker);
}

}  // namespace
}  // namespace lec6::serve::will_test

namespace lec6::serve::will_test {
namespace {

// The broker stalls (SIGSTOP) for longer than stop()'s grace while the client
// stops with a last QoS 1 message (a Sparkplug NDEATH): when it resumes, it
// answers on a socket the client had closed (broken pipe, the will) unless
// the client kept the connection open for it.
TEST(MqttClientWill, AStopWhileTheBrokerStallsNeverFiresTheWill) {
  Plant p("stall-checker");
  ASSERT_TRUE(p.up());
  std::atomic<bool> up{false};
  MqttClientHandlers h;
  h.connected = [&up] { up = true; };
  h.message = [](const MqttMessage&) {};
  MqttClient client(options(p.broker, "stall-client"), h);
  client.start();
  ASSERT_TRUE(wait_for([&] { return up.load(); }, 5s));
  client.subscribe({"in/#"});
  client.publish("t/warm", "x", 1, false);  // acknowledged: the SUBSCRIBE before it was read
  ASSERT_TRUE(wait_for([&] { return client.stats().pending == 0; }, 5s));
  ::kill(p.broker.pid, SIGSTOP);
  std::thread resume([&] {
    std::this_thread::sleep_for(2500ms);  // the stall: past the 2 s grace
    ::kill(p.broker.pid, SIGCONT);
  });
  client.stop({{"t/last", "bye"}}, 2s);
  resume.join();
  wait_for([&] { return p.checker.wills.load() > 0; }, 1500ms);
  EXPECT_EQ(p.checker.wills.load(), 0) << "the broker said:" << unclean_lines(p.broker);
}

// reconnect() while the broker stalls, after a QoS 1 publish (the Sparkplug
// node's own NDEATH on the host's offline STATE): the last words arrive once
// (libmosquitto would send an unacknowledged one again on the next
// connection), and the will never.
TEST(MqttClientWill, AReconnectWhileTheBrokerStallsSaysItsLastWordsOnce) {
  Plant p("redial-checker");
  ASSERT_TRUE(p.up());
  std::atomic<int> ups{0};
  MqttClient* self = nullptr;
  MqttClientHandlers h;
  h.connected = [&ups, &self] {
    ++ups;
    if (self) self->subscribe({"in/#"});
  };
  h.message = [](const MqttMessage&) {};
  MqttClient client(options(p.broker, "redial-client"), h);
  self = &client;
  client.start();
  ASSERT_TRUE(wait_for([&] { return ups.load() == 1 && client.stats().pending == 0; }, 5s));
  ::kill(p.broker.pid, SIGSTOP);
  client.publish("t/last", "bye", 1, false);
  client.reconnect();
  std::this_thread::sleep_for(2500ms);  // the stall
  ::kill(p.broker.pid, SIGCONT);
  EXPECT_TRUE(wait_for([&] { return ups.load() == 2; }, 15s)) << "no new connection";
  EXPECT_TRUE(wait_for([&] { return p.checker.lasts.load() > 0; }, 5s));
  wait_for([&] { return p.checker.lasts.load() > 1 || p.checker.wills.load() > 0; }, 1000ms);
  client.stop({}, 1s);
  EXPECT_EQ(p.checker.wills.load(), 0) << "the broker said:" << unclean_lines(p.broker);
  EXPECT_EQ(p.checker.lasts.load(), 1) << "the last QoS 1 message of the old connection";
}

// QoS 1 messages streaming in (a host's QoS 1 DCMDs): the broker still has
// some queued or in flight for the client when it stops; closed with them
// unread, the socket was reset and the broker published the will.
TEST(MqttClientWill, AStopWithAQos1BacklogNeverFiresTheWill) {
  Plant p("backlog-checker");
  ASSERT_TRUE(p.up());
  Peer flooder("backlog-flooder");
  ASSERT_TRUE(flooder.start(p.broker.port));
  std::atomic<bool> flooding{true};
  std::thread flood([&] {
    const std::string payload(64, 'x');
    while (flooding) {
      for (int k = 0; k < 50; ++k)
        mosquitto_publish(flooder.m, nullptr, "in/x", static_cast<int>(payload.size()),
                          payload.data(), 1, false);
      std::this_thread::sleep_for(1ms);
    }
  });
  constexpr int kRounds = 100;
  int stops = 0;
  for (int i = 0; i < kRounds; ++i) {
    std::atomic<bool> up{false};
    MqttClientHandlers h;
    h.connected = [&up] { up = true; };
    h.message = [](const MqttMessage&) {};
    MqttClient client(options(p.broker, "backlog-client-" + std::to_string(i)), h);
    client.start();
    if (!wait_for([&] { return up.load(); }, 5s)) continue;
    client.subscribe({"in/#"});
    wait_for([&] { return client.stats().received > 200; }, 3s);
    client.stop({{"t/last", "bye"}}, 2s);
    ++stops;
  }
  flooding = false;
  flood.join();
  wait_for([&] { return p.checker.wills.load() > 0; }, 1s);
  EXPECT_EQ(stops, kRounds);
  EXPECT_EQ(p.checker.wills.load(), 0)
      << "wills in " << kRounds << " stops; the broker said:" << unclean_lines(p.broker);
}

// A second reviewer's attacks on the lingering DISCONNECT.
// stop() while reconnect() redials a stalled broker: the new connection's
// CONNECT is written, its CONNACK not come; closed without a DISCONNECT,
// the broker (once it resumes) publishes the will.
TEST(MqttClientWill, AStopDuringARedialToAStalledBrokerNeverFiresTheWill) {
  Plant p("redial-stop-checker");
  ASSERT_TRUE(p.up());
  std::atomic<int> ups{0};
  MqttClientHandlers h;
  h.connected = [&ups] { ++ups; };
  h.message = [](const MqttMessage&) {};
  auto client = std::make_unique<MqttClient>(options(p.broker, "redial-stop-client"), h);
  client->start();
  ASSERT_TRUE(wait_for([&] { return ups.load() == 1; }, 5s));
  ::kill(p.broker.pid, SIGSTOP);
  client->reconnect();
  // The old connection lingers 2 s for the stalled broker, then the CONNECT
  // of the new one goes out: the stop comes after it.
  std::this_thread::sleep_for(2500ms);
  client->stop({{"t/last", "bye"}}, 1s);
  ::kill(p.broker.pid, SIGCONT);
  client.reset();  // lec serve exits right after stop()
  wait_for([&] { return p.checker.wills.load() > 0; }, 1500ms);
  EXPECT_EQ(p.checker.wills.load(), 0) << "the broker said:" << unclean_lines(p.broker);
}

// A QoS 1 backlog larger than the socket buffers, the broker stalled just past
// the grace: the DISCONNECT is queued behind megabytes; written as the socket
// takes them (never a read by libmosquitto between), it still goes out clean.
TEST(MqttClientWill, AStopBehindABacklogLargerThanTheSocketNeverFiresTheWill) {
  Plant p("backlog-stall-checker");
  ASSERT_TRUE(p.up());
  std::atomic<int> ups{0};
  MqttClientHandlers h;
  h.connected = [&ups] { ++ups; };
  h.message = [](const MqttMessage&) {};
  auto client = std::make_unique<MqttClient>(options(p.broker, "backlog-stall-client"), h);
  client->start();
  ASSERT_TRUE(wait_for([&] { return ups.load() == 1; }, 5s));
  ::kill(p.broker.pid, SIGSTOP);
  const std::string big(256 * 1024, 'y');
  for (int i = 0; i < 30; ++i) client->publish("b/big", big, 1, false);
  std::thread resume([&] {
    std::this_thread::sleep_for(1100ms);  // past the 1 s grace
    ::kill(p.broker.pid, SIGCONT);
  });
  client->stop({{"t/last", "bye"}}, 1s);
  resume.join();
  client.reset();
  wait_for([&] { return p.checker.wills.load() > 0; }, 1500ms);
  EXPECT_EQ(p.checker.wills.load(), 0) << "the broker said:" << unclean_lines(p.broker);
}

// A third reviewer's attacks.
// reconnect() with the broker stalled past the redial's drain: libmosquitto
// kept the unacknowledged last words and sent them again on the new
// connection (a second NDEATH); the new session now starts on a fresh handle.
TEST(MqttClientWill, AReconnectPastItsDrainNeverResendsTheOldSessionsMessages) {
  Plant p("drain-checker");
  ASSERT_TRUE(p.up());
  std::atomic<int> ups{0};
  MqttClientHandlers h;
  h.connected = [&ups] { ++ups; };
  h.message = [](const MqttMessage&) {};
  auto o = options(p.broker, "drain-client");
  o.redial_drain = 300ms;
  MqttClient client(o, h);
  client.start();
  ASSERT_TRUE(wait_for([&] { return ups.load() == 1 && client.stats().pending == 0; }, 5s));
  ::kill(p.broker.pid, SIGSTOP);
  client.publish("t/last", "bye", 1, false);
  client.reconnect();
  std::this_thread::sleep_for(1500ms);  // the stall: past the drain
  ::kill(p.broker.pid, SIGCONT);
  EXPECT_TRUE(wait_for([&] { return ups.load() == 2; }, 15s)) << "no new connection";
  EXPECT_TRUE(wait_for([&] { return p.checker.lasts.load() > 0; }, 5s));
  wait_for([&] { return p.checker.lasts.load() > 1; }, 1000ms);
  client.stop({}, 1s);
  EXPECT_EQ(p.checker.lasts.load(), 1) << "the old session's QoS 1 message, on the new connection";
  EXPECT_EQ(p.checker.wills.load(), 0) << "the broker said:" << unclean_lines(p.broker);
}

// stop() gives up waiting for a loop thread held in a slow handler; when the
// thread comes back it still sends the last words and the DISCONNECT (it left
// without them: the will).
TEST(MqttClientWill, AStopThatGaveUpOnASlowHandlerStillDisconnectsCleanly) {
  Plant p("slow-checker");
  ASSERT_TRUE(p.up());
  std::atomic<bool> up{false}, in_handler{false};
  MqttClient* self = nullptr;
  MqttClientHandlers h;
  h.connected = [&] {
    up = true;
    if (self) self->subscribe({"in/#"});
  };
  h.message = [&](const MqttMessage&) {
    in_handler = true;
    std::this_thread::sleep_for(5500ms);  // past stop()'s own bound (~4.5 s)
  };
  auto client = std::make_unique<MqttClient>(options(p.broker, "slow-client"), h);
  self = client.get();
  client->start();
  ASSERT_TRUE(wait_for([&] { return up.load() && client->stats().pending == 0; }, 5s));
  client->publish("t/warm", "x", 1, false);  // the SUBSCRIBE before it was read
  ASSERT_TRUE(wait_for([&] { return client->stats().pending == 0; }, 5s));
  mosquitto_publish(p.checker.m, nullptr, "in/x", 1, "x", 1, false);
  ASSERT_TRUE(wait_for([&] { return in_handler.load(); }, 5s));
  client->stop({{"t/last", "bye"}}, 1s);
  client.reset();
  wait_for([&] { return p.checker.lasts.load() > 0 || p.checker.wills.load() > 0; }, 2000ms);
  EXPECT_EQ(p.checker.wills.load(), 0) << "the broker said:" << unclean_lines(p.broker);
  EXPECT_EQ(p.checker.lasts.load(), 1);
}

// QoS 1 messages past the broker's receive maximum wait in libmosquitto; a
// QoS 1 last word waits behind them and the DISCONNECT overtook it: gone, and
// no will either. At last_qos 0 (the JSON bridge's "offline") it goes ahead.
TEST(MqttClientWill, LastWordsAtQos0GoAheadOfMessagesBeyondTheReceiveMaximum) {
  Plant p("quota-checker", "max_inflight_messages 2\n");
  ASSERT_TRUE(p.up());
  std::atomic<bool> up{false};
  MqttClientHandlers h;
  h.connected = [&up] { up = true; };
  h.message = [](const MqttMessage&) {};
  auto o = options(p.broker, "quota-client");
  o.last_qos = 0;
  auto client = std::make_unique<MqttClient>(o, h);
  client->start();
  ASSERT_TRUE(wait_for([&] { return up.load(); }, 5s));
  ::kill(p.broker.pid, SIGSTOP);
  for (int i = 0; i < 10; ++i) client->publish("b/x", "y", 1, false);
  std::thread resume([&] {
    std::this_thread::sleep_for(1500ms);  // past the 1 s grace
    ::kill(p.broker.pid, SIGCONT);
  });
  client->stop({{"t/last", "bye"}}, 1s);
  resume.join();
  client.reset();
  wait_for([&] { return p.checker.lasts.load() > 0 || p.checker.wills.load() > 0; }, 2000ms);
  EXPECT_EQ(p.checker.lasts.load(), 1);
  EXPECT_EQ(p.checker.wills.load(), 0) << "the broker said:" << unclean_lines(p.broker);
}

}  // namespace
}  // namespace lec6::serve::will_test
