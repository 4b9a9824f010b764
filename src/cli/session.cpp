#include <cstdlib>

#include "cli/app.hpp"
#include "cli/trace_printer.hpp"
#include "lec6/client/rtu_master.hpp"
#include "lec6/lec/step_data.hpp"
#include "lec6/lec/units.hpp"
#include "lec6/transport/capture_file.hpp"
#include "lec6/transport/port_spec.hpp"
#include "lec6/twin/field_profile.hpp"
#include "lec6/twin/line_recorder.hpp"
#include "lec6/twin/open_port.hpp"

namespace lec6::cli {

struct Session::Impl {
  std::unique_ptr<twin::LineRecorder> recorder;  // --record; outlives the port
  std::unique_ptr<twin::OpenPort> port;
  std::unique_ptr<client::Client> client;
  std::unique_ptr<client::Actuator> axis;
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

std::optional<client::SoftLimits> parse_soft_limits(const std::string& text) {
  if (text.empty()) return std::nullopt;
  const auto colon = text.find(':');
  const auto usage = [&](const std::string& why) {
    return UsageError(
        fmt::format("--soft-limits '{}': {}; expected MIN:MAX in mm, e.g. 0:400", text, why));
  };
  if (colon == std::string::npos) throw usage("no ':'");
  const auto end = [&](const std::string& part) {
    auto v = lec::parse_field(lec::StepField::Position, part);
    if (!v) throw usage(v.error());
    return static_cast<int32_t>(*v);
  };
  client::SoftLimits l{end(text.substr(0, colon)), end(text.substr(colon + 1))};
  if (l.min_001mm > l.max_001mm) throw usage("MIN is above MAX");
  return l;
}

twin::PortOptions line_port_options(const GlobalOptions& o) {
  twin::PortOptions po;
  po.baud = o.baud;
  po.silent_interval_k = o.silent_interval_k;
  po.delay_td = o.delay_td;
  po.timeout_margin = o.reply_margin;
  po.wait_for_silence = !o.no_silence_wait;
  po.reply_spin = o.reply_spin;
  po.discard_echo = o.echo;
  po.rs485.enabled = o.rs485;
  po.rs485.rts_after_send = o.rs485_rts_after_send;
  po.rs485.delay_before_send_ms = whole_ms(o.rs485_delay_before);
  po.rs485.delay_after_send_ms = whole_ms(o.rs485_delay_after);
  return po;
}

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
  twin::PortOptions po = line_port_options(options_);
  if (options_.trace) po.trace = print_trace_event;
  // Ctrl-C ends every wait on the line at once (exit 130); stop requests still go out.
  po.interrupted = [] { return g_interrupted.load(); };
  po.sim_id = static_cast<uint8_t>(options_.id);
  if (transport::parse_port_spec(text).kind == transport::PortKind::Sim) {
    try {
      po.sim_actuator = twin::named_profile(options_.sim_profile).actuator;
    } catch (const twin::ProfileError& e) {
      throw UsageError(
          fmt::format("--sim-profile: default, ideal or a field profile file: {}", e.what()));
    }
  }
  const auto spec = transport::parse_port_spec(text);
  if (!options_.record.empty() && spec.kind != transport::PortKind::Tcp) {
    keep_earlier_capture_said(options_.record);
    static const SteadyClock steady;  // every link but a --timing fast twin's runs on it
    impl->recorder = std::make_unique<twin::LineRecorder>(options_.record, "record", options_.baud,
                                                          text, steady);
    po.record = impl->recorder->tap();
  } else if (!options_.record.empty()) {
    po.record = [](transport::LineChunk&&) {};  // open_port refuses Modbus TCP with a reason
  }
  impl->port = twin::open_port(spec, po);
  for (const auto& w : impl->port->warnings()) fmt::print(stderr, "lec: warning: {}\n", w);
  client::ClientOptions co;
  co.id = static_cast<uint8_t>(options_.id);
  co.retries = options_.retries;
  co.alarm_polarity =
      lec::parse_alarm_polarity(options_.alarm_polarity).value_or(lec::AlarmPolarity::ActiveHigh);
  impl->client = std::make_unique<client::Client>(impl->port->master(), co);
  impl->axis = std::make_unique<client::Actuator>(*impl->client);
  impl->axis->set_soft_limits(parse_soft_limits(options_.soft_limits));
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
  return impl_ ? impl_->port->description() : std::string("(not open)");
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

void keep_earlier_capture_said(const std::string& path) {
  if (const auto kept = transport::keep_earlier_capture(path))
    fmt::print(stderr, "lec: kept the earlier capture {} as {}\n", path, *kept);
}

}  // namespace lec6::cli
