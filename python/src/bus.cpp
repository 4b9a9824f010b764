// lec6.Bus and _lec6.open_bus(): a port opened the way `lec` opens it
// (twin::open_port), shared by every Axis and thread that uses it.

#include <fmt/format.h>

#include "axis.hpp"
#include "bus.hpp"
#include "lec6/client/errors.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/transport/serial_link.hpp"
#include "lec6/twin/open_port.hpp"

namespace lec6::python {
namespace {

void check_range(std::string_view keyword, double value, double lo, double hi,
                 std::string_view unit = "") {
  if (!(value >= lo && value <= hi)) {
    throw client::InvalidRequest(fmt::format("{}={}: allowed {} to {}{}{}", keyword, value, lo, hi,
                                             unit.empty() ? "" : " ", unit));
  }
}

// Calls a Python trace(event) from the line's thread; its errors are reported
// as unraisable (they must not break the exchange).
client::TraceSink trace_sink(py::object trace) {
  if (trace.is_none()) return {};
  // The sink may be destroyed without the GIL (with the port): the last
  // reference is dropped under it.
  std::shared_ptr<py::object> holder(new py::object(std::move(trace)), [](py::object* p) {
    py::gil_scoped_acquire gil;
    delete p;
  });
  return [holder](const client::TraceEvent& e) {
    py::gil_scoped_acquire gil;
    try {
      (*holder)(py::dict(
          py::arg("direction") = e.outgoing ? "out" : "in",
          py::arg("time_s") = to_seconds(e.at.time_since_epoch()),
          py::arg("bytes") =
              py::bytes(reinterpret_cast<const char*>(e.bytes.data()), e.bytes.size()),
          py::arg("hex") = modbus::to_hex(e.bytes), py::arg("explanation") = e.explanation));
    } catch (py::error_already_set& err) {
      err.discard_as_unraisable("lec6 trace callback");
    }
  };
}

Bus open_bus(const std::string& port, uint32_t baud, int retries, double timeout_margin_ms,
             unsigned silent_interval, double delay_ms, bool silence_wait, bool echo, bool rs485,
             py::object trace, const std::string& alarm_polarity) {
  const lec::AlarmPolarity polarity = parse_polarity(alarm_polarity);
  if (!transport::is_supported_baud(baud)) {
    throw client::InvalidRequest(fmt::format(
        "baud={}: the controller supports 9600, 19200, 38400, 57600, 115200 and 230400", baud));
  }
  check_range("retries", retries, 0, 10);
  check_range("timeout_margin_ms", timeout_margin_ms, 0, 10000, "ms");
  check_range("silent_interval", silent_interval, 1, 100);
  check_range("delay_ms", delay_ms, 0, 1000, "ms");
  const transport::PortSpec spec = transport::parse_port_spec(port);  // ValueError with a hint
  twin::PortOptions o;
  o.baud = baud;
  o.silent_interval_k = silent_interval;
  o.delay_td = to_duration(FractionalMilliseconds(delay_ms));
  o.timeout_margin = to_duration(FractionalMilliseconds(timeout_margin_ms));
  o.wait_for_silence = silence_wait;
  o.discard_echo = echo;
  o.rs485.enabled = rs485;
  o.trace = trace_sink(std::move(trace));
  std::shared_ptr<twin::OpenPort> opened;
  {
    py::gil_scoped_release nogil;  // opening a serial port or a TCP connection can take a while
    opened = twin::open_port(spec, o);
  }
  for (const auto& w : opened->warnings()) PyErr_WarnEx(PyExc_RuntimeWarning, w.c_str(), 1);
  auto& master = opened->master();
  return Bus{std::make_shared<SharedLine>(std::move(opened), master, line_clock()), retries,
             polarity};
}

}  // namespace

lec::AlarmPolarity parse_polarity(const std::string& text) {
  if (const auto p = lec::parse_alarm_polarity(text)) return *p;
  throw client::InvalidRequest(
      fmt::format("alarm_polarity='{}': active-high (the manual: X4F = 1 is an alarm) or "
                  "active-low (X4F = 0 is an alarm)",
                  text));
}

void bind_bus(py::module_& m) {
  bind_axis(m);
  py::class_<Bus>(m, "Bus",
                  "An opened port: lec6.connect(...). Safe to share between threads: requests "
                  "take turns on the line, one transaction at a time, in arrival order.")
      .def(
          "axis",
          [](const Bus& b, int id, std::optional<std::string> alarm_polarity) {
            if (id < 1 || id > 255) {
              throw client::InvalidRequest(
                  fmt::format("axis id {}: controller IDs are 1-255 (0 is broadcast)", id));
            }
            client::ClientOptions o;
            o.id = static_cast<uint8_t>(id);
            o.retries = b.retries;
            o.alarm_polarity = alarm_polarity ? parse_polarity(*alarm_polarity) : b.alarm_polarity;
            return Axis{b.line, o, std::nullopt};
          },
          py::arg("id") = 1, py::kw_only(), py::arg("alarm_polarity") = py::none(),
          "The controller with this ID (1-255). alarm_polarity: how it reports X4F ALARM "
          "('active-high', the manual's, or 'active-low'); default: the bus's.")
      .def_property_readonly(
          "alarm_polarity",
          [](const Bus& b) { return std::string(lec::to_string(b.alarm_polarity)); },
          "How the bus's controllers report X4F ALARM, unless an axis says otherwise.")
      .def_property_readonly("port", [](const Bus& b) { return b.line->describe(); })
      .def_property_readonly("closed", [](const Bus& b) { return b.line->closed(); })
      .def(
          "stats",
          [](const Bus& b) {
            const auto s = b.line->totals();
            return py::dict(
                py::arg("transactions") = s.transactions, py::arg("retries") = s.retries,
                py::arg("timeouts") = s.timeouts, py::arg("crc_errors") = s.crc_errors,
                py::arg("framing_errors") = s.framing_errors, py::arg("exceptions") = s.exceptions,
                py::arg("bytes_discarded") = s.bytes_discarded);
          },
          "What the line did so far.")
      .def(
          "close",
          [](Bus& b) {
            py::gil_scoped_release nogil;  // waits for a transaction in progress
            b.line->close();
          },
          "Releases the port (after the transaction in progress); later calls raise "
          "TransportError.")
      .def("__enter__", [](Bus& b) -> Bus& { return b; })
      .def("__exit__",
           [](Bus& b, const py::args&) {
             py::gil_scoped_release nogil;
             b.line->close();
           })
      .def("__repr__", [](const Bus& b) { return fmt::format("Bus({})", b.line->describe()); });

  m.def("open_bus", &open_bus, py::arg("port"), py::arg("baud") = 38400, py::kw_only(),
        py::arg("retries") = 2, py::arg("timeout_margin_ms") = 50.0,
        py::arg("silent_interval") = 1u, py::arg("delay_ms") = 5.0, py::arg("silence_wait") = true,
        py::arg("echo") = false, py::arg("rs485") = false, py::arg("trace") = py::none(),
        py::arg("alarm_polarity") = "active-high", "The port behind lec6.connect() (see there).");
}

}  // namespace lec6::python
