#include "mqtt/mqtt_client.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <mosquitto.h>
#include <mqtt_protocol.h>
#include <poll.h>
#include <pthread.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <shared_mutex>
#include <stdexcept>
#include <thread>
#include <unordered_set>
#include <utility>

namespace lec6::serve {
namespace {

void init_library() {
  static std::once_flag once;
  std::call_once(once, [] { mosquitto_lib_init(); });
}

std::string error_text(int rc, int saved_errno) {
  if (rc == MOSQ_ERR_ERRNO) return std::strerror(saved_errno);
  return mosquitto_strerror(rc);
}

// Messages handed to libmosquitto and not yet written (QoS 0) or
// acknowledged (QoS 1), by message id. libmosquitto may report a message
// done before publish() has returned its id: that early report is kept until
// the id is recorded.
class PendingWindow {
 public:
  // Returns true when `mid` is still pending (not reported done already).
  bool sent(int mid) {
    if (early_.erase(mid) > 0) return false;
    pending_.insert(mid);
    return true;
  }
  void done(int mid) {
    if (pending_.erase(mid) == 0) early_.insert(mid);
    if (early_.size() > 65536) early_.clear();  // reports of messages from before a reset
  }
  // On connect: QoS 0 messages of the last connection are gone, QoS 1 ones
  // are sent again; both are forgotten rather than guessed at.
  void reset() {
    pending_.clear();
    early_.clear();
  }
  std::size_t size() const { return pending_.size(); }

 private:
  std::unordered_set<int> pending_, early_;
};

}  // namespace

struct MqttClient::Impl {
  MqttClientOptions o;
  MqttClientHandlers h;
  mosquitto* mosq = nullptr;
  // Held shared by every other thread's call into libmosquitto (publish,
  // subscribe, stop's last words), exclusively by the loop's thread while it
  // gives the handle a fresh session (fresh_handle).
  std::shared_mutex handle_mutex;
  std::thread thread;

  mutable std::mutex mutex;
  std::condition_variable cv;
  bool closing = false;   // stop() under way: no more reconnects
  bool stop_now = false;  // leave the loop
  bool stopped = false;
  bool connected = false;
  bool failing = false;  // the last attempt failed (report failures once)
  bool redial = false;   // reconnect() under way: connect again at once
  // reconnect() asked: DISCONNECT once what was queued is delivered (or at the deadline).
  bool redial_asked = false;
  std::chrono::steady_clock::time_point redial_deadline{};
  bool quit_asked = false;  // stop(): the loop's thread sends the DISCONNECT
  std::chrono::steady_clock::time_point quit_deadline{};       // ... once connected, until then
  std::vector<std::pair<std::string, std::string>> quit_last;  // stop()'s, when not connected
  bool quit_done = false;  // the loop's thread has left (or is leaving) the broker
  // How long a DISCONNECT keeps the connection open for the broker to read
  // it (disconnect_now).
  static constexpr auto kLinger = std::chrono::seconds(2);
  std::size_t reserved = 0;  // publishes between the bound check and their id
  PendingWindow window;
  std::unordered_set<int> awaited;  // stop()'s last messages
  MqttClientStats stats;

  void setup();
  void configure();
  void fresh_handle();
  void run();
  void disconnect_now();
  struct Step {
    bool disconnect = false;  // send the DISCONNECT now
    bool draining = false;    // a PUBACK or a CONNACK awaited: turn the loop fast
    std::vector<std::pair<std::string, std::string>> last;  // publish before the DISCONNECT
  };
  Step leave_step();
  void report_failure(const std::string& why);
  void wait_backoff(Duration d);

  static void on_connect(mosquitto*, void* obj, int rc, int, const mosquitto_property*);
  static void on_disconnect(mosquitto*, void* obj, int rc, const mosquitto_property*);
  static void on_publish(mosquitto*, void* obj, int mid, int, const mosquitto_property*);
  static void on_message(mosquitto*, void* obj, const mosquitto_message* m,
                         const mosquitto_property* props);
};

void MqttClient::Impl::setup() {
  init_library();
  mosq = mosquitto_new(o.client_id.c_str(), true, this);
  if (!mosq) throw std::runtime_error("mqtt: cannot create the client (out of memory)");
  configure();
}

// Every setting of the handle (setup(), and fresh_handle() after a reinitialise).
void MqttClient::Impl::configure() {
  mosquitto_int_option(mosq, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V5);
  mosquitto_int_option(mosq, MOSQ_OPT_TCP_NODELAY, 1);  // command results go out at once
  // Our own thread runs the loop; publishers on other threads only queue.
  mosquitto_threaded_set(mosq, true);
  mosquitto_connect_v5_callback_set(mosq, on_connect);
  mosquitto_disconnect_v5_callback_set(mosq, on_disconnect);
  mosquitto_publish_v5_callback_set(mosq, on_publish);
  mosquitto_message_v5_callback_set(mosq, on_message);
  auto check = [](int rc, const std::string& what) {
    if (rc != MOSQ_ERR_SUCCESS) {
      throw std::runtime_error(fmt::format("mqtt: {}: {}", what, error_text(rc, errno)));
    }
  };
  if (!o.will_topic.empty()) {
    check(mosquitto_will_set_v5(mosq, o.will_topic.c_str(), static_cast<int>(o.will_payload.size()),
                                o.will_payload.data(), 1, o.will_retain, nullptr),
          "the last will");
  }
  if (!o.username.empty()) {
    check(mosquitto_username_pw_set(mosq, o.username.c_str(),
                                    o.password.empty() ? nullptr : o.password.c_str()),
          "username and password");
  }
  if (o.url.tls) {
    auto c_str = [](const std::string& s) { return s.empty() ? nullptr : s.c_str(); };
    if (!o.ca_file.empty() || !o.cert_file.empty()) {
      check(
          mosquitto_tls_set(mosq, c_str(o.ca_file), o.ca_file.empty() ? "/etc/ssl/certs" : nullptr,
                            c_str(o.cert_file), c_str(o.key_file), nullptr),
          "TLS files");
    }
    if (o.ca_file.empty()) mosquitto_int_option(mosq, MOSQ_OPT_TLS_USE_OS_CERTS, 1);
  }
}

void MqttClient::Impl::report_failure(const std::string& why) {
  {
    std::lock_guard lock(mutex);
    if (failing) return;
    failing = true;
  }
  if (h.disconnected) h.disconnected(why);
}

void MqttClient::Impl::wait_backoff(Duration d) {
  std::unique_lock lock(mutex);
  cv.wait_for(lock, d, [this] { return closing || stop_now; });
}

// A clean DISCONNECT is one the broker reads before anything else goes wrong
// on the socket; otherwise it takes the client for lost and publishes the
// will: a Sparkplug NDEATH said twice for one bdSeq (attack.mjs,
// sigterm-after-offline, under the sanitizer at real-time priority;
// tests/serve/mqtt/mqtt_client_will_test.cpp). Two ways it went wrong:
// - libmosquitto 2 marks the connection disconnected as soon as the
//   DISCONNECT is queued, and a packet read before it is written (a PUBACK,
//   the host's STATE) is a protocol error that closes the socket without it.
//   So it is queued and written here, on the loop's thread, nothing read between.
// - libmosquitto closes its socket right after writing it. A socket closed
//   with data unread in it is reset, and a broker still writing to it (QoS 1
//   messages it had queued for us, an acknowledgement it owes) fails with a
//   broken pipe before it reads the DISCONNECT. So a duplicate of the socket
//   keeps the connection open, and what the broker still sends is read and
//   dropped until it closes the connection (on reading the DISCONNECT), at
//   most kLinger: our own lingering close, as libmosquitto has none.
void MqttClient::Impl::disconnect_now() {
  const int fd = mosquitto_socket(mosq);
  const int kept = fd >= 0 ? ::fcntl(fd, F_DUPFD_CLOEXEC, 0) : -1;
  mosquitto_disconnect_v5(mosq, MQTT_RC_NORMAL_DISCONNECTION, nullptr);
  const auto end = std::chrono::steady_clock::now() + kLinger;
  std::array<char, 4096> drop{};
  // Waits for `events` on the kept socket until `end`; false: time is up or it failed.
  const auto wait = [&](short events, short& got) {
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          end - std::chrono::steady_clock::now());
      if (left.count() <= 0) return false;
      pollfd p{kept, events, 0};
      const int n = ::poll(&p, 1, static_cast<int>(left.count()));
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return false;
      got = p.revents;
      return true;
    }
  };
  const auto drop_some = [&] {  // false: the broker closed, or the socket failed
    const ssize_t r = ::read(kept, drop.data(), drop.size());
    return r > 0 || (r < 0 && (errno == EINTR || errno == EAGAIN));
  };
  // Written whole, nothing read by libmosquitto between: what is queued
  // before the DISCONNECT may fill the socket, so it is written as the
  // socket takes it, and what the broker sends meanwhile is dropped (a
  // broker blocked on writing to us would never read on).
  mosquitto_loop_write(mosq, 1);
  while (kept >= 0 && mosquitto_socket(mosq) >= 0) {
    short got = 0;
    if (!wait(POLLIN | POLLOUT, got)) break;
    if ((got & POLLIN) && !drop_some()) break;
    if (got & (POLLOUT | POLLERR | POLLHUP)) mosquitto_loop_write(mosq, 1);
  }
  if (kept < 0) return;
  if (mosquitto_socket(mosq) >= 0) {  // never written (the broker took nothing for kLinger)
    ::close(kept);
    return;
  }
  // Written, and libmosquitto's socket closed: the kept one lingers until the broker closes.
  ::shutdown(kept, SHUT_WR);
  for (short got = 0; wait(POLLIN, got) && drop_some();) {
  }
  ::close(kept);
}

// On the loop's thread, between two turns of the loop: what a stop() or a
// reconnect() asked.
MqttClient::Impl::Step MqttClient::Impl::leave_step() {
  Step step;
  std::lock_guard lock(mutex);
  const auto now = std::chrono::steady_clock::now();
  if (quit_asked) {  // a stop() overrides a reconnect() under way
    redial_asked = false;
    if (connected) {
      quit_asked = false;
      step.last = std::move(quit_last);  // stop() could not send them: not connected then
      step.disconnect = true;
      return step;
    }
    // Not connected, a CONNECT perhaps on its way (a reconnect()
    // redialling): a connection that comes up by quit_deadline gets the last
    // words and the DISCONNECT. Past it the DISCONNECT goes anyway: after a
    // CONNECT the broker has not answered yet (stalled), it ends that session
    // cleanly; with nothing written yet, the socket is just closed. Closed
    // without it after a CONNECT, the broker would publish the will.
    if (now < quit_deadline) {
      step.draining = true;
      return step;
    }
    quit_asked = false;
    step.disconnect = true;
    return step;
  }
  if (!redial_asked) return step;
  // libmosquitto sends a QoS 1 message again on the next connection when its
  // PUBACK has not come: a Sparkplug NDEATH would be said twice. So the
  // DISCONNECT waits for what is in flight (at most o.redial_drain; past it
  // the handle's fresh session drops it: fresh_handle).
  const bool done = (window.size() == 0 && reserved == 0) || now >= redial_deadline;
  step.draining = !done;
  if (done) {
    redial_asked = false;
    redial = true;
    step.disconnect = true;
  }
  return step;
}

// Before a reconnect()'s new connection: libmosquitto keeps the old
// session's unacknowledged QoS 1 messages and sends them again on the next
// connection, clean start or not: a Sparkplug NDEATH would be said twice (a
// broker stalled past the redial's drain; a publish that slipped in before the
// DISCONNECT). Nothing of the old session may be said in the new one: the
// handle is reinitialised, with every other thread's call held off meanwhile.
void MqttClient::Impl::fresh_handle() {
  std::unique_lock hold(handle_mutex);
  mosquitto_reinitialise(mosq, o.client_id.c_str(), true, this);
  configure();
  std::lock_guard lock(mutex);
  window.reset();
}

// Connects, runs the network loop, and reconnects after any failure.
void MqttClient::Impl::run() {
  struct Done {  // stop() waits for this, however the loop ends
    Impl& s;
    ~Done() {
      {
        std::lock_guard lock(s.mutex);
        s.quit_done = true;
      }
      s.cv.notify_all();
    }
  } done{*this};
  Duration backoff = std::chrono::seconds(1);
  const Duration max_backoff = std::chrono::seconds(o.reconnect_max_s);
  bool first = true;
  for (;;) {
    uint64_t connects_before;
    {
      std::lock_guard lock(mutex);
      if (closing || stop_now) return;
      connects_before = stats.connects;
    }
    if (o.will_update) {
      const std::string will = o.will_update();
      mosquitto_will_set_v5(mosq, o.will_topic.c_str(), static_cast<int>(will.size()), will.data(),
                            1, o.will_retain, nullptr);
    }
    int rc = first ? mosquitto_connect_bind_async(mosq, o.url.host.c_str(), o.url.port,
                                                  static_cast<int>(o.keepalive_s), nullptr)
                   : mosquitto_reconnect_async(mosq);
    int saved_errno = errno;
    first = false;
    while (rc == MOSQ_ERR_SUCCESS) {
      {
        // A stop() that gave up waiting for this thread (a slow handler)
        // still gets its DISCONNECT here, before the thread leaves.
        std::lock_guard lock(mutex);
        if (stop_now && !quit_asked) return;
      }
      const Step step = leave_step();
      for (const auto& [topic, payload] : step.last)
        mosquitto_publish_v5(mosq, nullptr, topic.c_str(), static_cast<int>(payload.size()),
                             payload.data(), o.last_qos, o.last_retain, nullptr);
      if (step.disconnect) disconnect_now();
      // 50 ms: a stop()'s or reconnect()'s request waits at most this for the thread.
      rc = mosquitto_loop(mosq, step.draining ? 10 : 50, 1);
      saved_errno = errno;
    }
    bool fresh = false;
    {
      std::lock_guard lock(mutex);
      if (closing || stop_now) return;
      if (stats.connects != connects_before) backoff = std::chrono::seconds(1);
      fresh = std::exchange(redial, false);
    }
    if (fresh) {
      try {
        fresh_handle();
        first = true;  // a reinitialised handle connects anew
        continue;
      } catch (const std::exception& e) {  // the settings took before: not expected
        report_failure(e.what());
        wait_backoff(backoff);
        continue;
      }
    }
    report_failure(fmt::format("cannot reach the broker {}:{}: {}", o.url.host, o.url.port,
                               error_text(rc, saved_errno)));
    wait_backoff(backoff);
    backoff = std::min(backoff * 2, max_backoff);
  }
}

void MqttClient::Impl::on_connect(mosquitto*, void* obj, int rc, int, const mosquitto_property*) {
  auto* self = static_cast<Impl*>(obj);
  if (rc != 0) {
    self->report_failure(
        fmt::format("the broker refused the connection: {}", mosquitto_reason_string(rc)));
    return;
  }
  {
    std::lock_guard lock(self->mutex);
    self->connected = true;
    self->failing = false;
    self->redial_asked = false;  // a new connection: what reconnect() wanted is done
    ++self->stats.connects;
    self->window.reset();
  }
  if (self->h.connected) self->h.connected();
}

void MqttClient::Impl::on_disconnect(mosquitto*, void* obj, int rc, const mosquitto_property*) {
  auto* self = static_cast<Impl*>(obj);
  bool was;
  {
    std::lock_guard lock(self->mutex);
    was = self->connected;
    self->connected = false;
    if (was && rc != 0) self->failing = true;  // one report per outage
  }
  self->cv.notify_all();
  if (was && rc != 0 && self->h.disconnected) {
    self->h.disconnected(fmt::format("lost the broker: {}", error_text(rc, errno)));
  }
}

void MqttClient::Impl::on_publish(mosquitto*, void* obj, int mid, int, const mosquitto_property*) {
  auto* self = static_cast<Impl*>(obj);
  {
    std::lock_guard lock(self->mutex);
    self->window.done(mid);
    self->awaited.erase(mid);
  }
  self->cv.notify_all();
}

void MqttClient::Impl::on_message(mosquitto*, void* obj, const mosquitto_message* m,
                                  const mosquitto_property* props) {
  auto* self = static_cast<Impl*>(obj);
  MqttMessage msg;
  msg.topic = m->topic;
  msg.payload.assign(static_cast<const char*>(m->payload), static_cast<std::size_t>(m->payloadlen));
  msg.retain = m->retain;
  char* text = nullptr;
  if (mosquitto_property_read_string(props, MQTT_PROP_RESPONSE_TOPIC, &text, false)) {
    msg.response_topic = text;
    std::free(text);
  }
  void* data = nullptr;
  uint16_t len = 0;
  if (mosquitto_property_read_binary(props, MQTT_PROP_CORRELATION_DATA, &data, &len, false)) {
    msg.correlation = std::string(static_cast<const char*>(data), len);
    std::free(data);
  }
  uint32_t expiry = 0;
  if (mosquitto_property_read_int32(props, MQTT_PROP_MESSAGE_EXPIRY_INTERVAL, &expiry, false)) {
    msg.expiry_s = expiry;
  }
  {
    std::lock_guard lock(self->mutex);
    ++self->stats.received;
  }
  if (self->h.message) self->h.message(msg);
}

// ---- the client -------------------------------------------------------------------

MqttClient::MqttClient(MqttClientOptions options, MqttClientHandlers handlers)
    : impl_(std::make_unique<Impl>()) {
  impl_->o = std::move(options);
  impl_->h = std::move(handlers);
  try {
    impl_->setup();
  } catch (...) {
    if (impl_->mosq) mosquitto_destroy(impl_->mosq);
    throw;
  }
}

MqttClient::~MqttClient() {
  stop({}, Duration{});
  mosquitto_destroy(impl_->mosq);
}

void MqttClient::start() {
  std::lock_guard lock(impl_->mutex);
  if (impl_->thread.joinable() || impl_->stopped) return;
  impl_->thread = std::thread([this] {
    ::pthread_setname_np(::pthread_self(), impl_->o.thread_name.substr(0, 15).c_str());
    impl_->run();
  });
}

bool MqttClient::publish(const std::string& topic, std::string_view payload, int qos, bool retain,
                         const ReplyTo* reply) {
  Impl& s = *impl_;
  {
    std::lock_guard lock(s.mutex);
    if ((qos == 0 && !s.connected) || s.window.size() + s.reserved >= s.o.max_pending) {
      ++s.stats.dropped;
      return false;
    }
    ++s.reserved;
  }
  mosquitto_property* props = nullptr;
  if (reply && !reply->correlation.empty()) {
    mosquitto_property_add_binary(&props, MQTT_PROP_CORRELATION_DATA, reply->correlation.data(),
                                  static_cast<uint16_t>(reply->correlation.size()));
  }
  int mid = 0;
  std::shared_lock hold(s.handle_mutex);
  const int rc = mosquitto_publish_v5(s.mosq, &mid, topic.c_str(), static_cast<int>(payload.size()),
                                      payload.data(), qos, retain, props);
  mosquitto_property_free_all(&props);
  std::lock_guard lock(s.mutex);
  --s.reserved;
  if (rc != MOSQ_ERR_SUCCESS) {
    ++s.stats.dropped;
    return false;
  }
  s.window.sent(mid);
  ++s.stats.published;
  return true;
}

void MqttClient::subscribe(const std::vector<std::string>& filters) {
  // Retain-as-published: a retained command is seen as one. Never the
  // retained messages already stored (a stale command must not arrive),
  // except on the filters that ask for them (retained_filters).
  std::shared_lock hold(impl_->handle_mutex);
  for (const bool retained : {false, true}) {
    std::vector<char*> subs;
    for (const auto& f : filters) {
      const auto& keep = impl_->o.retained_filters;
      if ((std::find(keep.begin(), keep.end(), f) != keep.end()) == retained)
        subs.push_back(const_cast<char*>(f.c_str()));
    }
    if (subs.empty()) continue;
    mosquitto_subscribe_multiple(
        impl_->mosq, nullptr, static_cast<int>(subs.size()), subs.data(), 1,
        MQTT_SUB_OPT_RETAIN_AS_PUBLISHED |
            (retained ? MQTT_SUB_OPT_SEND_RETAIN_ALWAYS : MQTT_SUB_OPT_SEND_RETAIN_NEVER),
        nullptr);
  }
}

void MqttClient::stop(const std::vector<std::pair<std::string, std::string>>& last,
                      Duration grace) {
  Impl& s = *impl_;
  bool was_connected;
  {
    std::lock_guard lock(s.mutex);
    if (s.stopped) return;
    s.stopped = true;
    was_connected = s.connected;
  }
  const auto deadline = std::chrono::steady_clock::now() + grace;
  if (was_connected) {
    std::shared_lock hold(s.handle_mutex);
    for (const auto& [topic, payload] : last) {
      int mid = 0;
      if (mosquitto_publish_v5(s.mosq, &mid, topic.c_str(), static_cast<int>(payload.size()),
                               payload.data(), s.o.last_qos, s.o.last_retain,
                               nullptr) == MOSQ_ERR_SUCCESS) {
        std::lock_guard lock(s.mutex);
        if (s.window.sent(mid)) s.awaited.insert(mid);
      }
    }
  }
  {
    std::unique_lock lock(s.mutex);
    if (was_connected)
      s.cv.wait_until(lock, deadline, [&s] { return s.awaited.empty() || !s.connected; });
    else
      s.quit_last = last;  // sent if a connection comes up before the DISCONNECT
    // The loop's thread sends the DISCONNECT (leave_step, disconnect_now):
    // at once when connected, else once a connection under way is up (a
    // reconnect() redialling), at most 1 s from now.
    s.closing = true;
    s.quit_asked = true;
    const auto now = std::chrono::steady_clock::now();
    s.quit_deadline = now + std::chrono::seconds(1);
    if (s.thread.joinable()) {
      s.cv.notify_all();
      s.cv.wait_until(
          lock,
          std::max(deadline, s.quit_deadline) + Impl::kLinger + std::chrono::milliseconds(500),
          [&s] { return s.quit_done; });
    }
    s.stop_now = true;
  }
  s.cv.notify_all();
  if (s.thread.joinable()) s.thread.join();
}

void MqttClient::reconnect() {
  std::lock_guard lock(impl_->mutex);
  if (!impl_->connected || impl_->stopped || impl_->redial_asked) return;
  impl_->redial_asked = true;
  impl_->redial_deadline = std::chrono::steady_clock::now() + impl_->o.redial_drain;
}

bool MqttClient::connected() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->connected;
}

MqttClientStats MqttClient::stats() const {
  std::lock_guard lock(impl_->mutex);
  MqttClientStats s = impl_->stats;
  s.connected = impl_->connected;
  s.pending = impl_->window.size();
  return s;
}

}  // namespace lec6::serve
