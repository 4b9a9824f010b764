#pragma once
// Opens what a configured line talks through: a serial port, RTU frames over
// TCP, or the built-in twin (`port: sim`), each under an RtuMaster with the
// line's timing. The twin of a sim line is reachable for the dashboard's
// twin panel (only from the line's thread: Line::post).
//
// Thread safety: open_wire() may be called from any thread; the twin it
// returns belongs to the line's thread.

#include <memory>

#include "lec6/serve/config.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/transport/recording_link.hpp"
#include "line/line.hpp"

namespace lec6::serve {

// The in-process twin behind a sim line.
struct SimWire {
  SteadyClock clock;
  std::unique_ptr<sim::Bus> bus;
  std::unique_ptr<client::Link> link;
};

// Throws TransportError/LinkError when the port cannot be opened. With a
// `record` tap, every byte of the line also goes to it (lec serve --record).
Wire open_wire(const LineConfig& line, transport::LineTap record = {});

// The scheduler settings a configured line implies.
SchedulerConfig scheduler_config(const LineConfig& line);

}  // namespace lec6::serve
