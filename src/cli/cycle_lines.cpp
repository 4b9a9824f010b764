#include "cli/cycle_lines.hpp"

#include "cli/profile_option.hpp"

#include "lec6/client/actuator.hpp"
#include "lec6/client/rtu_master.hpp"
#include "lec6/lec/alarm_check.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/twin/open_port.hpp"
#include "lec6/twin/sim_link.hpp"

namespace lec6::cli {

struct CycleLines::Impl {
  // Simulated: every line a twin bus on one virtual clock.
  VirtualClock clock{TimePoint{} + std::chrono::seconds(1)};
  std::vector<std::unique_ptr<sim::Bus>> buses;
  std::vector<std::unique_ptr<twin::SimLink>> links;
  std::vector<std::unique_ptr<client::RtuMaster>> sim_masters;
  // Real: the ports as open_port opens them.
  std::vector<std::unique_ptr<twin::OpenPort>> ports;
  std::map<std::string, std::unique_ptr<client::Client>> clients;  // by axis
  std::vector<std::string> descriptions;
  std::map<std::string, sim::Bus*> twin_bus;  // by axis
};

CycleLines::CycleLines(const cycle::Cycle& cycle, const GlobalOptions& globals,
                       const std::string& port, const std::string& profile_file)
    : impl_(std::make_unique<Impl>()) {
  std::map<std::string, std::vector<const cycle::Axis*>> by_line;
  for (const auto& a : cycle.axes) by_line[a.line].push_back(&a);
  if (by_line.count("") && port.empty()) {
    throw UsageError(
        "no port given for the axes without `line:`: use --port sim (the in-process twin), "
        "/dev/ttyUSB0, tcp://host:502, or set LEC_PORT");
  }
  simulated_ = port == "sim";
  if (!profile_file.empty() && !simulated_) {
    throw UsageError("--profile sets up the twin: it goes with --port sim");
  }
  const twin::FieldProfile profile = profile_option(profile_file);
  client::ClientOptions co;
  co.retries = globals.retries;
  co.alarm_polarity =
      lec::parse_alarm_polarity(globals.alarm_polarity).value_or(lec::AlarmPolarity::ActiveHigh);
  for (const auto& [line, axes] : by_line) {
    client::Master* master = nullptr;
    if (simulated_) {
      sim::LineConfig lc = profile.line;
      if (!profile.given.count("line.baud")) lc.line.baud = globals.baud;
      if (!profile.given.count("line.silent_interval")) {
        lc.line.silent_interval_k = globals.silent_interval_k;
      }
      if (!profile.given.count("line.delay_ms")) lc.line.delay_td = globals.delay_td;
      auto bus = std::make_unique<sim::Bus>(lc, profile.faults);
      for (const auto* a : axes) {
        sim::ActuatorConfig config = profile.actuator;
        config.workpiece_mm = a->twin_workpiece_mm;
        bus->add(a->id, config, impl_->clock.now());
        impl_->twin_bus[a->name] = bus.get();
      }
      impl_->links.push_back(std::make_unique<twin::SimLink>(*bus, impl_->clock));
      client::RtuOptions ro;
      ro.silent_interval_k = lc.line.silent_interval_k;
      ro.delay_td = lc.line.delay_td;
      ro.timeout_margin = globals.reply_margin;
      impl_->sim_masters.push_back(std::make_unique<client::RtuMaster>(*impl_->links.back(), ro));
      impl_->buses.push_back(std::move(bus));
      master = impl_->sim_masters.back().get();
      impl_->descriptions.push_back(fmt::format("{}in-process twin @ {}, profile {}",
                                                line.empty() ? "" : line + " as ", lc.line.baud,
                                                profile.name));
    } else {
      const std::string text = line.empty() ? port : line;
      impl_->ports.push_back(
          twin::open_port(transport::parse_port_spec(text), line_port_options(globals)));
      for (const auto& w : impl_->ports.back()->warnings())
        fmt::print(stderr, "lec: warning: {}\n", w);
      master = &impl_->ports.back()->master();
      impl_->descriptions.push_back(impl_->ports.back()->description());
    }
    for (const auto* a : axes) {
      client::ClientOptions c = co;
      c.id = a->id;
      impl_->clients[a->name] = std::make_unique<client::Client>(*master, c);
    }
  }
}

CycleLines::~CycleLines() = default;

std::map<std::string, client::Client*> CycleLines::clients() {
  std::map<std::string, client::Client*> out;
  for (auto& [name, c] : impl_->clients) out[name] = c.get();
  return out;
}

sim::Bus* CycleLines::twin_bus(const std::string& axis) {
  const auto it = impl_->twin_bus.find(axis);
  return it == impl_->twin_bus.end() ? nullptr : it->second;
}

const Clock& CycleLines::clock() const {
  if (simulated_) return impl_->clock;
  return impl_->clients.begin()->second->clock();
}

std::string CycleLines::describe() const {
  std::string out;
  for (const auto& d : impl_->descriptions) out += (out.empty() ? "" : ", ") + d;
  return out;
}

void CycleLines::prepare(const cycle::Cycle& cycle) {
  for (const auto& a : cycle.axes) {
    client::Actuator act(*impl_->clients.at(a.name));
    act.set_serial_mode(true);
    act.servo_on(act.deadline_in(std::chrono::seconds(5)));
    act.home(act.deadline_in(std::chrono::seconds(60)));
  }
}

}  // namespace lec6::cli
