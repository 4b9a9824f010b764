// lec6.Twin: the controller twin (sim::Bus) in this process, for testing
// scripts without hardware. In process, it is driven through twin::SimLink on
// the steady clock, one exchange at a time (the SharedLine); with pty=True a
// twin::SimServer serves it on a pseudo-terminal from its own thread, for
// other programs or lec6.connect(twin.port).

#include <fmt/format.h>

#include <thread>

#include "bus.hpp"
#include "lec6/client/errors.hpp"
#include "lec6/client/rtu_master.hpp"
#include "lec6/transport/serial_link.hpp"
#include "lec6/twin/field_profile.hpp"
#include "lec6/twin/sim_link.hpp"
#include "lec6/twin/sim_server.hpp"

namespace lec6::python {
namespace {

struct TwinSettings {
  std::vector<int> ids;
  std::string timing;
  std::string profile;  // its name: "default", "ideal", or the file's
  sim::ActuatorConfig actuator;
  sim::LineConfig line;
  sim::FaultConfig faults;
};

// The in-process twin: everything one exchange touches.
struct InProcess {
  SteadyClock clock;
  sim::Bus bus;
  twin::SimLink link;
  client::RtuMaster master;

  InProcess(const TwinSettings& s, const client::RtuOptions& rtu)
      : bus(s.line, s.faults), link(bus, clock), master(link, rtu) {}
};

// The pty twin: a SimServer's loop on its own thread.
struct Served {
  sim::Bus bus;
  std::unique_ptr<twin::SimServer> server;
  std::thread thread;
  std::exception_ptr failure;

  explicit Served(const TwinSettings& s) : bus(s.line, s.faults) {}
  ~Served() { stop(); }
  Served(const Served&) = delete;
  Served& operator=(const Served&) = delete;
  void stop() {
    if (!thread.joinable()) return;
    server->stop();
    thread.join();
    server.reset();  // removes the pty (and its symlink)
  }
};

class Twin {
 public:
  Twin(TwinSettings s, const py::object& pty) : settings_(std::move(s)) {
    if (pty.is_none() || (py::isinstance<py::bool_>(pty) && !pty.cast<bool>())) {
      start_in_process();
    } else {
      start_served(
          py::isinstance<py::bool_>(pty)
              ? std::string()
              : py::str(py::module_::import("os").attr("fspath")(pty)).cast<std::string>());
    }
  }
  ~Twin() { close(); }

  Bus connect(int retries, const std::string& alarm_polarity) {
    if (closed_)
      throw client::TransportError(client::TransportErrorKind::Port, "the twin was closed");
    if (line_) return Bus{line_, retries, parse_polarity(alarm_polarity)};
    auto open_bus = py::module_::import("lec6._lec6").attr("open_bus");
    return open_bus(port(), settings_.line.line.baud, py::arg("retries") = retries,
                    py::arg("alarm_polarity") = alarm_polarity,
                    py::arg("silence_wait") = settings_.line.timing != sim::Timing::Fast)
        .cast<Bus>();
  }

  std::string port() const {
    if (served_ && served_->server) return served_->server->pty()->client_path();
    return "in-process";
  }

  void close() {
    if (closed_) return;
    closed_ = true;
    py::gil_scoped_release nogil;
    if (line_) line_->close();
    if (served_) served_->stop();
  }

  // Touches a controller of the in-process twin between exchanges.
  template <typename F>
  void with_controller(int id, F&& f) {
    if (!line_) throw client::InvalidRequest("only the in-process twin (pty=False) takes inputs");
    py::gil_scoped_release nogil;
    line_->with_line([&](void* owner) {
      auto* twin = static_cast<InProcess*>(owner);
      if (!twin)
        throw client::TransportError(client::TransportErrorKind::Port, "the twin was closed");
      sim::Controller* c =
          id >= 1 && id <= 255 ? twin->bus.find(static_cast<uint8_t>(id)) : nullptr;
      if (!c) throw client::InvalidRequest(fmt::format("the twin has no controller {}", id));
      f(*c, twin->clock.now());
    });
  }

  const TwinSettings& settings() const { return settings_; }
  bool closed() const { return closed_; }

 private:
  void add_controllers(sim::Bus& bus, TimePoint now) {
    for (int id : settings_.ids) {
      if (id < 1 || id > 255)
        throw client::InvalidRequest(
            fmt::format("ids: {} is not a controller ID (1-255; 0 is the broadcast address)", id));
      bus.add(static_cast<uint8_t>(id), settings_.actuator, now);  // duplicates: invalid_argument
    }
  }

  void start_in_process() {
    client::RtuOptions rtu;
    rtu.silent_interval_k = settings_.line.line.silent_interval_k;
    rtu.delay_td = settings_.line.line.delay_td;
    // A fast twin frames by length, like `lec --no-silence-wait` expects.
    rtu.wait_for_silence = settings_.line.timing != sim::Timing::Fast;
    auto twin = std::make_shared<InProcess>(settings_, rtu);
    add_controllers(twin->bus, twin->clock.now());
    auto& master = twin->master;
    line_ = std::make_shared<SharedLine>(std::move(twin), master, line_clock());
  }

  void start_served(const std::string& link) {
    served_ = std::make_unique<Served>(settings_);
    add_controllers(served_->bus, SteadyClock().now());
    twin::SimServerOptions so;
    so.pty = true;
    so.pty_link = link;
    served_->server = std::make_unique<twin::SimServer>(served_->bus, std::move(so));
    Served* s = served_.get();
    s->thread = std::thread([s] {
      try {
        s->server->run();
      } catch (...) {
        s->failure = std::current_exception();
      }
    });
  }

  TwinSettings settings_;
  std::shared_ptr<SharedLine> line_;  // in process
  std::unique_ptr<Served> served_;    // pty
  bool closed_ = false;
};

// A fault keyword: given, it replaces the profile's value; None keeps it.
void rate(std::string_view keyword, std::optional<double> r, double& into) {
  if (!r) return;
  if (!(*r >= 0.0 && *r <= 1.0))
    throw client::InvalidRequest(
        fmt::format("{}={}: a probability per reply, 0 to 1", keyword, *r));
  into = *r;
}

// profile: "default" (the field evidence), "ideal" (the manual's), or a
// profile file (lec sim --profile's) read over the default.
twin::FieldProfile twin_profile(const py::object& profile) {
  const std::string name = py::str(py::module_::import("os").attr("fspath")(profile));
  try {
    return twin::named_profile(name);
  } catch (const twin::ProfileError& e) {
    throw client::InvalidRequest(
        fmt::format("profile: 'default', 'ideal' or a field profile file: {}", e.what()));
  }
}

std::unique_ptr<Twin> make_twin(
    std::vector<int> ids, const std::string& timing, std::optional<double> workpiece_mm,
    std::optional<std::pair<double, double>> stroke_mm, std::optional<double> initial_position_mm,
    std::optional<double> max_speed_mm_s, std::optional<std::string> name,
    std::optional<double> drop_rate, std::optional<double> corrupt_rate,
    std::optional<double> garbage_rate, std::optional<double> delay_rate,
    std::optional<double> extra_delay_ms, std::optional<uint64_t> seed, uint32_t baud,
    const py::object& pty, const py::object& profile) {
  TwinSettings s;
  if (ids.empty()) throw client::InvalidRequest("ids: give at least one controller ID (1-255)");
  s.ids = std::move(ids);
  // The profile first; every keyword given replaces its value.
  const twin::FieldProfile fp = twin_profile(profile);
  s.profile = fp.name.empty() ? py::str(profile).cast<std::string>() : fp.name;
  s.actuator = fp.actuator;
  s.line = fp.line;
  s.faults = fp.faults;
  if (timing != "fast" && timing != "real")
    throw client::InvalidRequest(fmt::format("timing='{}': 'fast' or 'real'", timing));
  s.timing = timing;
  s.line.timing = timing == "fast" ? sim::Timing::Fast : sim::Timing::Real;
  if (!transport::is_supported_baud(baud))
    throw client::InvalidRequest(fmt::format(
        "baud={}: the controller supports 9600, 19200, 38400, 57600, 115200 and 230400", baud));
  s.line.line.baud = baud;
  if (stroke_mm) {
    s.actuator.stroke_min_mm = stroke_mm->first;
    s.actuator.stroke_max_mm = stroke_mm->second;
  }
  if (initial_position_mm) s.actuator.initial_position_mm = *initial_position_mm;
  if (workpiece_mm) s.actuator.workpiece_mm = workpiece_mm;
  if (max_speed_mm_s) s.actuator.max_speed_mm_s = *max_speed_mm_s;
  if (name) s.actuator.equipment_name = *name;
  if (auto problems = sim::validate(s.actuator); !problems.empty()) {
    std::string all;
    for (const auto& p : problems) all += (all.empty() ? "" : "; ") + p;
    throw client::InvalidRequest("Twin: " + all);
  }
  rate("drop_rate", drop_rate, s.faults.drop);
  rate("corrupt_rate", corrupt_rate, s.faults.corrupt);
  rate("garbage_rate", garbage_rate, s.faults.garbage);
  rate("delay_rate", delay_rate, s.faults.delay);
  if (extra_delay_ms) {
    if (!(*extra_delay_ms >= 0 && *extra_delay_ms <= 10000))
      throw client::InvalidRequest("extra_delay_ms: 0 to 10000 ms");
    s.faults.extra_delay = to_duration(FractionalMilliseconds(*extra_delay_ms));
  }
  if (seed) s.faults.seed = *seed;
  return std::make_unique<Twin>(std::move(s), pty);
}

}  // namespace

void bind_twin(py::module_& m) {
  py::class_<Twin>(m, "Twin",
                   "The controller twin, for testing scripts without hardware: in this process "
                   "(default), or on a pseudo-terminal (pty=True, or a path for a symlink) that "
                   "any Modbus master can open. profile: 'default' (the field's evidence: BUSY "
                   "20 ms late, homing at 50 mm/s, ...), 'ideal' (the manual's controller), or a "
                   "profile file as lec sim --profile reads (e.g. from lec sim --calibrate); "
                   "every other keyword given replaces the profile's value. Use as a context "
                   "manager, or close() it.")
      .def(py::init(&make_twin), py::arg("ids") = std::vector<int>{1}, py::kw_only(),
           py::arg("timing") = "fast", py::arg("workpiece_mm") = py::none(),
           py::arg("stroke_mm") = py::none(), py::arg("initial_position_mm") = py::none(),
           py::arg("max_speed_mm_s") = py::none(), py::arg("name") = py::none(),
           py::arg("drop_rate") = py::none(), py::arg("corrupt_rate") = py::none(),
           py::arg("garbage_rate") = py::none(), py::arg("delay_rate") = py::none(),
           py::arg("extra_delay_ms") = py::none(), py::arg("seed") = py::none(),
           py::arg("baud") = 38400, py::arg("pty") = false, py::arg("profile") = "default")
      // keep_alive: the twin lives as long as a bus to it, so that
      // `lec6.Twin().connect()` does not close the twin under its bus.
      .def("connect", &Twin::connect, py::kw_only(), py::arg("retries") = 2,
           py::arg("alarm_polarity") = "active-high", py::keep_alive<0, 1>(),
           "A Bus to this twin (in process: all share one line).")
      .def_property_readonly("port", &Twin::port,
                             "The pty path to open (pty twins), or 'in-process'.")
      .def_property_readonly("ids", [](const Twin& t) { return t.settings().ids; })
      .def_property_readonly("timing", [](const Twin& t) { return t.settings().timing; })
      .def_property_readonly(
          "profile", [](const Twin& t) { return t.settings().profile; },
          "The twin's profile: 'default', 'ideal', or the name of the file's profile.")
      .def_property_readonly("closed", &Twin::closed)
      .def(
          "set_estop",
          [](Twin& t, int id, bool on) {
            t.with_controller(id,
                              [on](sim::Controller& c, TimePoint now) { c.set_estop(on, now); });
          },
          py::arg("id"), py::arg("on") = true,
          "The EMG stop input of controller `id` (in-process twins).")
      .def(
          "set_workpiece",
          [](Twin& t, int id, std::optional<double> mm) {
            t.with_controller(
                id, [mm](sim::Controller& c, TimePoint now) { c.set_workpiece(mm, now); });
          },
          py::arg("id"), py::arg("mm"),
          "Puts a workpiece under controller `id`'s carriage at `mm` (None takes it away), e.g. "
          "for one axis of a cycle that pushes (workpiece_mm= puts one under every axis). Only "
          "while that carriage is at rest (in-process twins).")
      .def(
          "carriage_mm",
          [](Twin& t, int id) {
            double mm = 0;
            t.with_controller(
                id, [&mm](sim::Controller& c, TimePoint now) { mm = c.position_mm(now); });
            return mm;
          },
          py::arg("id") = 1,
          "Where the twin's carriage is (reported position, mm), read without the bus.")
      .def("close", &Twin::close,
           "Stops the twin (its pty or TCP server) and closes the buses connected to it; "
           "`with` does this.")
      .def("__enter__", [](Twin& t) -> Twin& { return t; })
      .def("__exit__", [](Twin& t, const py::args&) { t.close(); })
      .def("__repr__", [](const Twin& t) {
        std::string ids;
        for (int id : t.settings().ids) ids += (ids.empty() ? "" : ", ") + std::to_string(id);
        return fmt::format("Twin(ids=[{}], timing='{}', profile='{}', port='{}')", ids,
                           t.settings().timing, t.settings().profile, t.port());
      });
}

}  // namespace lec6::python
