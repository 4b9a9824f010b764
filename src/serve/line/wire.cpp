#include "line/wire.hpp"

#include "lec6/client/rtu_master.hpp"
#include "lec6/error.hpp"
#include "lec6/transport/port_spec.hpp"
#include "lec6/transport/serial_link.hpp"
#include "lec6/transport/tcp_link.hpp"
#include "lec6/twin/sim_link.hpp"

namespace lec6::serve {
namespace {

client::RtuOptions rtu_options(const LineConfig& line, bool fast_twin) {
  client::RtuOptions o;
  o.silent_interval_k = line.silent_interval;
  o.delay_td = to_duration(FractionalMilliseconds(line.delay_ms));
  o.timeout_margin = to_duration(FractionalMilliseconds(line.timeout_margin_ms));
  // A fast twin frames by length: the Ts gap would only measure itself.
  o.wait_for_silence = line.silence_wait && !fast_twin;
  return o;
}

std::shared_ptr<SimWire> make_twin(const LineConfig& line) {
  auto twin = std::make_shared<SimWire>();
  sim::LineConfig lc;
  lc.line.baud = line.baud;
  lc.line.silent_interval_k = line.silent_interval;
  lc.line.delay_td = to_duration(FractionalMilliseconds(line.delay_ms));
  lc.timing = line.sim.fast ? sim::Timing::Fast : sim::Timing::Real;
  sim::FaultConfig faults;
  faults.drop = line.sim.drop_rate;
  faults.corrupt = line.sim.corrupt_rate;
  faults.garbage = line.sim.garbage_rate;
  faults.seed = line.sim.seed;
  twin->bus = std::make_unique<sim::Bus>(lc, faults);
  sim::ActuatorConfig ac = line.sim.actuator;  // the profile: default, ideal or a file
  ac.stroke_max_mm = line.sim.stroke_max_mm;
  ac.initial_position_mm = line.sim.initial_position_mm;
  ac.workpiece_mm = line.sim.workpiece_mm;
  ac.wear_pct_per_m = line.sim.wear_pct_per_m;  // issue 26
  for (const auto& axis : line.axes) {
    if (!line.sim.absent_ids.contains(axis.id)) twin->bus->add(axis.id, ac, twin->clock.now());
  }
  twin->link = std::make_unique<twin::SimLink>(*twin->bus, twin->clock);
  return twin;
}

}  // namespace

Wire open_wire(const LineConfig& line, transport::LineTap record) {
  const auto spec = transport::parse_port_spec(line.port);
  Wire w;
  client::Link* link = nullptr;
  switch (spec.kind) {
    case transport::PortKind::Sim: {
      auto twin = make_twin(line);
      link = twin->link.get();
      w.twin = twin->bus.get();
      w.keep = twin;
      break;
    }
    case transport::PortKind::Serial: {
      transport::SerialOptions so;
      so.baud = line.baud;
      so.discard_echo = line.echo;
      so.rs485.enabled = line.rs485.enabled;
      so.rs485.rts_after_send = line.rs485.rts_after_send;
      so.rs485.delay_before_send_ms = line.rs485.delay_before_ms;
      so.rs485.delay_after_send_ms = line.rs485.delay_after_ms;
      auto serial = std::make_shared<transport::SerialLink>(spec.device, so);
      link = serial.get();
      w.keep = serial;
      break;
    }
    case transport::PortKind::RtuOverTcp: {
      transport::TcpOptions to;
      to.baud = line.baud;
      to.scheme = "rtu+tcp";
      auto tcp = std::make_shared<transport::TcpLink>(spec.host, spec.tcp_port, to);
      link = tcp.get();
      w.keep = tcp;
      break;
    }
    case transport::PortKind::Tcp:
      throw InvalidArgument("a line is driven in Modbus RTU, not Modbus TCP: " + line.port);
  }
  if (record) {  // the recording link keeps what the link needed alive
    struct Recorded {
      std::shared_ptr<void> inner;
      std::unique_ptr<transport::RecordingLink> link;
    };
    auto r = std::make_shared<Recorded>();
    r->inner = std::move(w.keep);
    r->link = std::make_unique<transport::RecordingLink>(*link, std::move(record));
    link = r->link.get();
    w.keep = r;
  }
  const bool fast_twin = spec.kind == transport::PortKind::Sim && line.sim.fast;
  w.master = std::make_unique<client::RtuMaster>(*link, rtu_options(line, fast_twin));
  return w;
}

SchedulerConfig scheduler_config(const LineConfig& line) {
  SchedulerConfig s;
  for (const auto& a : line.axes) {
    const Duration period = a.telemetry_hz > 0
                                ? to_duration(FractionalMilliseconds(1000.0 / a.telemetry_hz))
                                : Duration{};
    s.axes.push_back({a.id, period, a.alarm_polarity});
  }
  s.offline_after = line.offline_after;
  s.probe_interval = to_duration(FractionalMilliseconds(line.probe_interval_ms));
  s.poll_max_wait = to_duration(FractionalMilliseconds(line.poll_max_wait_ms));
  s.timing.baud = line.baud;
  s.timing.silent_interval_k = line.silent_interval;
  s.timing.delay_td = to_duration(FractionalMilliseconds(line.delay_ms));
  return s;
}

}  // namespace lec6::serve
