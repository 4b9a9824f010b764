#pragma once
// Opens what a user names as a port (transport::parse_port_spec) and gives
// the Master to build Clients on: one rule for every front-end (`lec`, the
// Python module) of how each kind of port is reached.
//
//   auto port = lec6::twin::open_port(lec6::transport::parse_port_spec("/dev/ttyUSB0"), {});
//   lec6::client::Client c(port->master(), {.id = 1});
//
//   serial device  → SerialLink + RtuMaster (the manual's timing)
//   rtu+tcp://     → TcpLink + RtuMaster
//   tcp://         → ModbusTcpMaster (a gateway, e.g. `lec serve`)
//   sim            → a twin bus in this process (one controller) + SimLink + RtuMaster
//
// It lives in twin/ because `sim` needs the twin; the other kinds only need
// transport/.
//
// Thread safety and lifetime: open_port may be called from any thread. An
// OpenPort owns everything behind its master (link, clock, in-process twin) and
// must outlive every Client made on master(); its master is used by one thread
// at a time (client::SharedMaster shares it between threads). The twin() of a
// `sim` port is touched only between exchanges, by the thread using the master.

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lec6/client/master.hpp"
#include "lec6/sim/behaviour.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/transport/port_spec.hpp"
#include "lec6/transport/recording_link.hpp"
#include "lec6/transport/serial_link.hpp"

namespace lec6::twin {

struct PortOptions {
  // The serial line and the controller's settings (digest §1). Behind a
  // Modbus TCP gateway they only serve for limits and timeouts.
  uint32_t baud = modbus::kDefaultBaud;
  unsigned silent_interval_k = 1;
  Duration delay_td = std::chrono::milliseconds(5);
  Duration timeout_margin = std::chrono::milliseconds(50);  // added to Tx (tcp://: to a second)
  bool wait_for_silence = true;                             // see client::RtuOptions
  Duration reply_spin{};                                    // see client::RtuOptions
  // Serial devices only.
  bool discard_echo = false;  // 2-wire adapters that echo what they send
  transport::Rs485Options rs485{};
  // Every frame, when set.
  client::TraceSink trace{};
  // Ctrl-C: ends waits on the line (see client::RtuOptions::interrupted).
  std::function<bool()> interrupted{};
  // The seed of the master's pause after a failure (client::RtuOptions::backoff_seed):
  // a simulation that gives it replays exactly, whatever ran before in the process.
  std::optional<uint32_t> backoff_seed{};
  // `sim`: the ID of its one controller, and the controller: the default twin
  // of `lec sim` (the field's evidence, sim::default_config()) unless told
  // otherwise (`lec --sim-profile ideal`: sim::ideal_config()).
  uint8_t sim_id = 1;
  sim::ActuatorConfig sim_actuator = sim::default_config();
  // Every byte on the line, both directions (`lec --record`), when set; RTU
  // links only (a tcp:// Modbus TCP port is refused: it is not a line).
  transport::LineTap record{};
};

// Everything behind one opened port. Not movable: the links keep references
// to the clock and the twin it holds.
class OpenPort {
 public:
  OpenPort() = default;
  OpenPort(const OpenPort&) = delete;
  OpenPort& operator=(const OpenPort&) = delete;

  client::Master& master() { return *master_; }
  // The in-process twin for `sim`; null otherwise.
  sim::Bus* twin() { return twin_.get(); }
  // "/dev/ttyUSB0 @ 38400", "tcp://host:502 (Modbus TCP)", "in-process twin".
  const std::string& description() const { return description_; }
  // What the serial port setup could not do (e.g. low latency refused).
  const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  friend std::unique_ptr<OpenPort> open_port(const transport::PortSpec&, const PortOptions&);
  friend std::unique_ptr<OpenPort> open_port_over(std::unique_ptr<client::Link>,
                                                  const PortOptions&);
  // The RTU master over link_ (recorded, with PortOptions::record).
  void attach_master(const PortOptions& options);
  SteadyClock clock_;
  std::unique_ptr<sim::Bus> twin_;
  std::unique_ptr<client::Link> link_;
  std::unique_ptr<transport::RecordingLink> recording_;  // over link_, with PortOptions::record
  std::unique_ptr<client::Master> master_;               // declared last: destroyed first
  std::string description_;
  std::vector<std::string> warnings_;
};

// Opens the port at once. Throws client::LinkError / client::TransportError
// when it cannot be opened (the message names it).
std::unique_ptr<OpenPort> open_port(const transport::PortSpec& spec,
                                    const PortOptions& options = {});

// A port over a link the caller made, as open_port builds one over a serial
// link (the master, its timing, recording): an in-process line of twins on
// a virtual clock (twin::VirtualLine), for what probes a line in tests.
std::unique_ptr<OpenPort> open_port_over(std::unique_ptr<client::Link> link,
                                         const PortOptions& options = {});

}  // namespace lec6::twin
