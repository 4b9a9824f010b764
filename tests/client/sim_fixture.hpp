#pragma once
// A client talking to a real twin bus in the same process, on a virtual
// clock: every wait is a clock jump, so tests run in no wall time and never
// sleep to synchronise.

#include <memory>
#include <vector>

#include "lec6/client/actuator.hpp"
#include "lec6/client/client.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/twin/sim_link.hpp"

namespace lec6::testing {

struct SimFixture {
  explicit SimFixture(sim::LineConfig line = {}, std::vector<uint8_t> ids = {1},
                      sim::ActuatorConfig config = {})
      : bus(line) {
    for (uint8_t id : ids) bus.add(id, config, clock.now());
    link = std::make_unique<twin::SimLink>(bus, clock);
    client = std::make_unique<client::Client>(*link, options());
    axis = std::make_unique<client::Actuator>(*client);
  }

  // A new Client (and Actuator) on the same line with these options (the
  // trace is kept).
  void reconnect(client::ClientOptions o) {
    axis.reset();
    client.reset();
    client = std::make_unique<client::Client>(*link, options(std::move(o)));
    axis = std::make_unique<client::Actuator>(*client);
  }

  client::ClientOptions options(client::ClientOptions o = {}) {
    o.trace = [this](const client::TraceEvent& e) {
      if (e.outgoing) sent.push_back(modbus::Bytes(e.bytes.begin(), e.bytes.end()));
      if (on_trace) on_trace(e);
    };
    return o;
  }

  // The manual's preparation: serial mode, servo on, home.
  void prepare() {
    axis->set_serial_mode(true);
    axis->servo_on(axis->deadline_in(std::chrono::seconds(2)));
    axis->home(axis->deadline_in(std::chrono::seconds(60)));
  }

  VirtualClock clock{TimePoint{} + std::chrono::seconds(1)};
  sim::Bus bus;
  std::unique_ptr<twin::SimLink> link;
  std::unique_ptr<client::Client> client;
  std::unique_ptr<client::Actuator> axis;
  std::vector<modbus::Bytes> sent;
  std::function<void(const client::TraceEvent&)> on_trace;
};

}  // namespace lec6::testing
