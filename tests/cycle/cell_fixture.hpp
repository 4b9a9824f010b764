#pragma once
// A cell on the in-process twin for the cycle tests: one line, a controller
// per axis of the cycle, one RtuMaster, a Client per axis, on a virtual
// clock (every wait is a clock jump: no wall time, no sleeps).

#include <map>
#include <memory>
#include <string>

#include "lec6/client/actuator.hpp"
#include "lec6/client/rtu_master.hpp"
#include "lec6/cycle/cycle_file.hpp"
#include "lec6/cycle/runner.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/twin/sim_link.hpp"

namespace lec6::testing {

struct Cell {
  explicit Cell(const std::string& yaml, bool prepare = true)
      : cycle(cycle::parse_cycle(yaml, "cell.yaml")), bus(sim::LineConfig{}) {
    for (const auto& a : cycle.axes) {
      sim::ActuatorConfig config;
      config.workpiece_mm = a.twin_workpiece_mm;
      bus.add(a.id, config, clock.now());
    }
    link = std::make_unique<twin::SimLink>(bus, clock);
    master = std::make_unique<client::RtuMaster>(*link);
    for (const auto& a : cycle.axes) {
      clients[a.name] =
          std::make_unique<client::Client>(*master, client::ClientOptions{.id = a.id});
    }
    if (prepare) {
      for (const auto& a : cycle.axes) ready(a.name);
    }
  }

  // Serial mode, servo on, home.
  void ready(const std::string& axis) {
    client::Actuator act(*clients.at(axis));
    act.set_serial_mode(true);
    act.servo_on(act.deadline_in(std::chrono::seconds(2)));
    act.home(act.deadline_in(std::chrono::seconds(60)));
  }

  int32_t position_001mm(const std::string& axis) {
    return clients.at(axis)->read_state().position_001mm;
  }

  cycle::CycleReport run(cycle::RunOptions options = {}) {
    std::map<std::string, client::Client*> raw;
    for (auto& [name, c] : clients) raw[name] = c.get();
    cycle::Runner runner(cycle, raw, std::move(options));
    return runner.run();
  }

  VirtualClock clock{TimePoint{} + std::chrono::seconds(1)};
  cycle::Cycle cycle;
  sim::Bus bus;
  std::unique_ptr<twin::SimLink> link;
  std::unique_ptr<client::RtuMaster> master;
  std::map<std::string, std::unique_ptr<client::Client>> clients;
};

}  // namespace lec6::testing
