#pragma once
// An RS485 line of in-process twins on a VirtualClock, with the line faults
// `lec sim` plays on its pseudo-terminal (twin/sim_server.hpp), so that what
// probes a line (lec doctor) runs in unit tests in no wall time. Like SimLink,
// waiting jumps the clock; nothing here sleeps or reads the wall clock.
//
//   sim::Bus bus(line, faults);            // Td, Ts, noise, duplicate IDs: the bus's own
//   bus.add(1);
//   VirtualClock clock;
//   VirtualLine vl(bus, clock, {.echo_adapter = true});
//   auto link = vl.open(38400);            // the master's port at one rate
//   client::RtuMaster master(*link);
//
// What the master's port hears, each at the instant its last bit is in (in
// real timing; fast timing takes no wire time): every reply and every noise
// byte the bus puts on the line (to any master), the other master's queries,
// and with an echoing adapter its own bytes as they leave. Every master's
// bytes reach the bus one after the other (the line carries one character at
// a time, as lec sim's virtual line does): a query the other master starts
// while ours is on the wire follows ours, and ours follows one of its.
//
// The faults, as lec sim plays them:
//  - echo_adapter: what the master writes comes back to it, byte for byte,
//    as it leaves (never garbled: its UART hears itself at its own rate);
//  - a port at another rate than the bus's: what the master sends reaches
//    the controllers garbled and it hears everything else garbled
//    (sim/wrong_baud.hpp), decided when the bytes are put on the line;
//  - other_master_period: another master reads D9000 x 7 of other_master_id
//    at origin + k x period (origin: the clock when the line is made);
//  - usb_latency: the master's adapter hands over what it heard in lumps at
//    origin + k x latency (sim/usb_latency.hpp), its own echo too (lec sim
//    writes the echo at once, a pty's shortcut).
//
// open() is a port opened anew: what arrived before it is dropped (as
// SerialLink's flush on open); what is still on its way arrives. The line's
// state (the other master's schedule, the adapter, the bus) carries over.
// A link holds the line's state: it may outlive the VirtualLine.
//
// Thread safety: one thread at a time, the same one that uses its Bus and clock.

#include <cstdint>
#include <memory>

#include "lec6/client/link.hpp"
#include "lec6/clock.hpp"
#include "lec6/sim/bus.hpp"

namespace lec6::twin {

struct VirtualLineOptions {
  // A 2-wire adapter: the master hears its own bytes back (lec sim --echo-adapter).
  bool echo_adapter = false;
  // > 0: another master reads D9000 x 7 (lec::kStateData, kStateDataRegisters) of
  // other_master_id this often, as sim_server's other_master_period.
  Duration other_master_period{};
  uint8_t other_master_id = 1;
  // > 0: the master's replies handed over in lumps at latency-timer ticks
  // (sim::UsbLatency, as lec sim --usb-latency).
  Duration usb_latency{};
};

class VirtualLine {
 public:
  // `bus` and `clock` outlive the line and every link it opened.
  VirtualLine(sim::Bus& bus, VirtualClock& clock, VirtualLineOptions options = {});
  ~VirtualLine();
  VirtualLine(const VirtualLine&) = delete;
  VirtualLine& operator=(const VirtualLine&) = delete;

  // The master's end of the line, its port set to `baud`. At a rate other than the bus's
  // (bus.line().line.baud) the UART garbles both ways, as lec sim's strict baud does on a pty.
  // discard_echo: the link drops its own echo, as transport::SerialLink does with discard_echo
  // (the same check: an echo that differs, or is not all back within its wire time + 50 ms,
  // throws LinkError EchoMismatch).
  // One link open at a time is enough (the doctor opens the port anew per baud rate);
  // the other master's schedule and the line's state carry over between links.
  // Throws LinkError PortUnavailable while another link of this line is open (a port held
  // exclusively, as SerialLink holds one).
  std::unique_ptr<client::Link> open(uint32_t baud, bool discard_echo = false);

 private:
  struct State;  // the line, shared with its links (virtual_line.cpp)
  class Port;    // a link
  std::shared_ptr<State> state_;
};

}  // namespace lec6::twin
