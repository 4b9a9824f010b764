#include <cstdlib>

#include "cli/app.hpp"
#include "cli/trace_printer.hpp"
#include "lec6/lec/units.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/transport/modbus_tcp_master.hpp"
#include "lec6/transport/port_spec.hpp"
#include "lec6/transport/serial_link.hpp"
#include "lec6/transport/tcp_link.hpp"
#include "lec6/twin/sim_link.hpp"

namespace lec6::cli {

struct Session::Impl {
  SteadyClock clock;
  std::unique_ptr<sim::Bus> twin;          // only for --port sim
  std::unique_ptr<client::Link> link;      // RTU on bytes: serial, rtu+tcp://, sim
  std::unique_ptr<client::Master> master;  // Modbus TCP: tcp://
  std::unique_ptr<client::Client> client;
  std::unique_ptr<client::Actuator> axis;
  std::string description;
};

Session::Session(const GlobalOptions& options) : options_(options) {}
Session::~Session() = default;

namespace {

std::string ports_found() {
  const auto ports = transport::list_serial_ports();
  if (ports.empty()) return "no serial ports were found on this machine";
  std::string out = "serial ports found:";
  for (const auto& p : ports) out += fmt::format("\n  {}  {}", p.path, p.description);
  return out;
}

std::string resolve_port(const GlobalOptions& o, std::string_view default_port) {
  if (!o.port.empty()) return o.port;
  if (const char* env = std::getenv("LEC_PORT"); env && *env) return env;
  if (!default_port.empty()) return std::string(default_port);
  throw UsageError(fmt::format(
      "no port given: use --port /dev/ttyUSB0 (or tcp://host:502 for Modbus TCP, e.g. lec "
      "serve, or sim for the built-in twin), or set "
      "LEC_PORT\n{}",
      ports_found()));
}

}  // namespace

client::Client& Session::client(std::string_view default_port) {
  if (impl_) return *impl_->client;
  if (options_.id == modbus::kBroadcastId && !allow_broadcast_) {
    throw UsageError(
        "--id 0 is broadcast: controllers do not answer it, so this command, which reads from the "
        "controller, cannot work; only writes can be broadcast: `lec --id 0 serial on|off`, "
        "`lec --id 0 hold on|off`, `lec --id 0 stop`");
  }
  auto impl = std::make_unique<Impl>();
  const std::string text = resolve_port(options_, default_port);
  const transport::PortSpec spec = transport::parse_port_spec(text);
  switch (spec.kind) {
    case transport::PortKind::Serial: {
      transport::SerialOptions so;
      so.baud = options_.baud;
      so.discard_echo = options_.echo;
      so.rs485.enabled = options_.rs485;
      so.rs485.rts_after_send = options_.rs485_rts_after_send;
      so.rs485.delay_before_send_ms = static_cast<uint32_t>(options_.rs485_delay_before_ms);
      so.rs485.delay_after_send_ms = static_cast<uint32_t>(options_.rs485_delay_after_ms);
      auto serial = std::make_unique<transport::SerialLink>(spec.device, so);
      for (const auto& w : serial->warnings()) fmt::print(stderr, "lec: warning: {}\n", w);
      impl->link = std::move(serial);
      break;
    }
    case transport::PortKind::RtuOverTcp: {
      transport::TcpOptions to;
      to.baud = options_.baud;
      to.scheme = "rtu+tcp";
      impl->link = std::make_unique<transport::TcpLink>(spec.host, spec.tcp_port, to);
      break;
    }
    case transport::PortKind::Tcp: {
      transport::ModbusTcpOptions mo;
      mo.line.baud = options_.baud;
      mo.line.silent_interval_k = options_.silent_interval_k;
      mo.line.delay_td = to_duration(FractionalMilliseconds(options_.delay_td_ms));
      // The gateway queues us behind other clients on its line: a second on
      // top of the serial reply window.
      mo.timeout =
          std::chrono::seconds(1) + to_duration(FractionalMilliseconds(options_.timeout_margin_ms));
      if (options_.trace) mo.trace = print_trace_event;
      impl->master = std::make_unique<transport::ModbusTcpMaster>(spec.host, spec.tcp_port, mo);
      break;
    }
    case transport::PortKind::Sim: {
      sim::LineConfig line;
      line.line.baud = options_.baud;
      line.line.silent_interval_k = options_.silent_interval_k;
      line.line.delay_td = to_duration(FractionalMilliseconds(options_.delay_td_ms));
      impl->twin = std::make_unique<sim::Bus>(line);
      impl->twin->add(static_cast<uint8_t>(options_.id), sim::ActuatorConfig{}, impl->clock.now());
      impl->link = std::make_unique<twin::SimLink>(*impl->twin, impl->clock);
      break;
    }
  }
  impl->description = impl->link ? impl->link->describe() : impl->master->describe();
  client::ClientOptions co;
  co.id = static_cast<uint8_t>(options_.id);
  co.retries = options_.retries;
  co.timeout_margin = to_duration(FractionalMilliseconds(options_.timeout_margin_ms));
  co.silent_interval_k = options_.silent_interval_k;
  co.delay_td = to_duration(FractionalMilliseconds(options_.delay_td_ms));
  co.wait_for_silence = !options_.no_silence_wait;
  if (options_.trace) co.trace = print_trace_event;
  // Ctrl-C ends every wait on the line at once (exit 130); stop requests still go out.
  co.interrupted = [] { return g_interrupted.load(); };
  impl->client = impl->link ? std::make_unique<client::Client>(*impl->link, co)
                            : std::make_unique<client::Client>(*impl->master, co);
  impl->axis = std::make_unique<client::Actuator>(*impl->client);
  impl_ = std::move(impl);
  return *impl_->client;
}

client::Actuator& Session::axis(std::string_view default_port) {
  client(default_port);
  return *impl_->axis;
}

void Session::close() noexcept {
  impl_.reset();
}

std::string Session::port_description() const {
  return impl_ ? impl_->description : std::string("(not open)");
}

client::WaitOptions Session::wait_options(
    std::function<void(const client::Progress&)> progress) const {
  client::WaitOptions w;
  w.progress = std::move(progress);
  w.cancel = [] { return g_interrupted.load(); };
  return w;
}

TimePoint Session::deadline_in(Duration d) {
  return client().clock().now() + d;
}

}  // namespace lec6::cli
