#include "lec6/twin/open_port.hpp"

#include <fmt/format.h>

#include "lec6/client/rtu_master.hpp"
#include "lec6/error.hpp"
#include "lec6/transport/modbus_tcp_master.hpp"
#include "lec6/transport/tcp_link.hpp"
#include "lec6/twin/sim_link.hpp"

namespace lec6::twin {

namespace {

modbus::LineTiming line_timing(const PortOptions& o) {
  modbus::LineTiming line;
  line.baud = o.baud;
  line.silent_interval_k = o.silent_interval_k;
  line.delay_td = o.delay_td;
  return line;
}

client::RtuOptions rtu_options(const PortOptions& o) {
  client::RtuOptions r;
  r.silent_interval_k = o.silent_interval_k;
  r.delay_td = o.delay_td;
  r.timeout_margin = o.timeout_margin;
  r.wait_for_silence = o.wait_for_silence;
  r.reply_spin = o.reply_spin;
  r.trace = o.trace;
  r.interrupted = o.interrupted;
  r.backoff_seed = o.backoff_seed;
  return r;
}

}  // namespace

std::unique_ptr<OpenPort> open_port(const transport::PortSpec& spec, const PortOptions& options) {
  auto port = std::make_unique<OpenPort>();
  switch (spec.kind) {
    case transport::PortKind::Serial: {
      transport::SerialOptions so;
      so.baud = options.baud;
      so.discard_echo = options.discard_echo;
      so.rs485 = options.rs485;
      auto serial = std::make_unique<transport::SerialLink>(spec.device, so);
      port->warnings_ = serial->warnings();
      port->link_ = std::move(serial);
      break;
    }
    case transport::PortKind::RtuOverTcp: {
      transport::TcpOptions to;
      to.baud = options.baud;
      to.scheme = "rtu+tcp";
      port->link_ = std::make_unique<transport::TcpLink>(spec.host, spec.tcp_port, to);
      break;
    }
    case transport::PortKind::Tcp: {
      if (options.record) {
        throw InvalidArgument(fmt::format(
            "--record records a serial line (Modbus RTU); {} is Modbus TCP: record on the "
            "machine that owns the line (lec serve --record FILE)",
            spec.host));
      }
      transport::ModbusTcpOptions mo;
      mo.line = line_timing(options);
      // The gateway queues us behind other clients on its line: a second on
      // top of the serial reply window.
      mo.timeout = std::chrono::seconds(1) + options.timeout_margin;
      mo.trace = options.trace;
      port->master_ = std::make_unique<transport::ModbusTcpMaster>(spec.host, spec.tcp_port, mo);
      break;
    }
    case transport::PortKind::Sim: {
      sim::LineConfig line;
      line.line = line_timing(options);
      port->twin_ = std::make_unique<sim::Bus>(line);
      port->twin_->add(options.sim_id, options.sim_actuator, port->clock_.now());
      port->link_ = std::make_unique<SimLink>(*port->twin_, port->clock_);
      break;
    }
  }
  if (port->link_) port->attach_master(options);
  port->description_ = port->master_->describe();
  return port;
}

std::unique_ptr<OpenPort> open_port_over(std::unique_ptr<client::Link> link,
                                         const PortOptions& options) {
  auto port = std::make_unique<OpenPort>();
  port->link_ = std::move(link);
  port->attach_master(options);
  port->description_ = port->master_->describe();
  return port;
}

void OpenPort::attach_master(const PortOptions& options) {
  client::Link* link = link_.get();
  if (options.record) {
    recording_ = std::make_unique<transport::RecordingLink>(*link, options.record);
    link = recording_.get();
  }
  master_ = std::make_unique<client::RtuMaster>(*link, rtu_options(options));
}

}  // namespace lec6::twin
