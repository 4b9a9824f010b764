// `lec replay FILE`: re-sends a capture's queries to the twin or a port and
// reports how the replies compare (issue 24, docs/replay.md). The file is
// read and checked whole before anything is opened or sent; the comparison
// is twin/replay.hpp's (sans-I/O), this file only does the I/O.

#include <fstream>
#include <set>

#include "cli/app.hpp"
#include "cli/profile_option.hpp"
#include "lec6/client/rtu_master.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/transport/capture_file.hpp"
#include "lec6/transport/port_spec.hpp"
#include "lec6/twin/field_profile.hpp"
#include "lec6/twin/open_port.hpp"
#include "lec6/twin/replay.hpp"
#include "lec6/twin/replay_run.hpp"
#include "lec6/twin/sim_link.hpp"

namespace lec6::cli {
namespace {

struct ReplayArgs {
  std::string file;
  std::string against = "sim";
  std::string timing = "as-captured";
  std::string profile;
  bool ideal = false;  // --ideal: against the manual's ideal twin instead of the default
  std::string report;
  double position_tolerance_mm = twin::ReplayTolerance{}.position_mm;
  double response_tolerance_pct = twin::ReplayTolerance{}.response_ratio * 100.0;
  double edge_tolerance_ms = twin::ReplayTolerance{}.edge_ms;
};

// The IDs the capture's queries address (the twin gets one controller each).
std::set<uint8_t> ids_in(const std::vector<twin::Exchange>& exchanges) {
  std::set<uint8_t> ids;
  for (const auto& e : exchanges)
    if (!e.query.empty() && e.query[0] != modbus::kBroadcastId) ids.insert(e.query[0]);
  return ids;
}

std::vector<twin::Exchange> replay_on_twin(const ReplayArgs& a, const modbus::Capture& capture,
                                           const std::vector<twin::Exchange>& captured,
                                           twin::ReplayTiming timing) {
  twin::FieldProfile p = profile_option(a.profile, a.ideal);
  // The twin times its replies at the captured line's speed.
  p.line.line.baud = capture.header.line.baud;
  p.line.timing = sim::Timing::Real;
  VirtualClock clock{TimePoint{} + std::chrono::seconds(1)};
  sim::Bus bus(p.line, p.faults);
  for (uint8_t id : ids_in(captured)) bus.add(id, p.actuator, clock.now());
  twin::SimLink link(bus, clock);
  client::RtuOptions o;
  o.silent_interval_k = p.line.line.silent_interval_k;
  o.delay_td = p.line.line.delay_td;
  client::RtuMaster master(link, o);
  return twin::run_replay(master, captured, timing);
}

std::vector<twin::Exchange> replay_on_port(const ReplayArgs& a, const GlobalOptions& g,
                                           const modbus::Capture& capture,
                                           const std::vector<twin::Exchange>& captured,
                                           twin::ReplayTiming timing) {
  const auto& line = capture.header.line;
  if (line.baud != g.baud) {
    throw UsageError(fmt::format(
        "{}, line 1: the capture was taken at {} baud, the port would be opened at {} (--baud); "
        "replay it at the captured speed: lec --baud {} replay …; nothing was sent",
        a.file, line.baud, g.baud, line.baud));
  }
  twin::PortOptions po = line_port_options(g);  // the line's options as every command's
  po.interrupted = [] { return g_interrupted.load(); };
  auto port = twin::open_port(transport::parse_port_spec(a.against), po);
  return twin::run_replay(port->master(), captured, timing);
}

void run_replay_command(const ReplayArgs& a, const GlobalOptions& g) {
  // Read and check the whole file before opening anything.
  const modbus::Capture capture = transport::read_capture_file(a.file);
  twin::check_replayable(capture, a.file);
  const auto captured = twin::pair_exchanges(twin::line_records(capture));
  const auto timing =
      a.timing == "fast" ? twin::ReplayTiming::Fast : twin::ReplayTiming::AsCaptured;
  const bool on_twin = a.against == "sim";
  const auto replayed = on_twin ? replay_on_twin(a, capture, captured, timing)
                                : replay_on_port(a, g, capture, captured, timing);
  twin::ReplayTolerance tol;
  tol.position_mm = a.position_tolerance_mm;
  tol.response_ratio = a.response_tolerance_pct / 100.0;
  tol.edge_ms = a.edge_tolerance_ms;
  auto report = twin::compare(captured, replayed, tol);
  report.timing = timing;
  report.target =
      on_twin ? (a.profile.empty() ? std::string("twin") : fmt::format("twin ({})", a.profile))
              : a.against;
  if (!a.report.empty()) {
    std::ofstream out(a.report, std::ios::binary | std::ios::trunc);
    out << report.json() << "\n";
    if (!out) throw CommandFailed(kFailure, fmt::format("cannot write {}", a.report));
  }
  if (g.json) {
    fmt::print("{}\n", report.json());
  } else {
    fmt::print("{}", report.text());
  }
  if (!report.matches()) throw CommandFailed(kFailure, "the replay differs from the capture");
}

}  // namespace

void add_replay_command(CLI::App& app, const GlobalOptions& globals) {
  auto a = std::make_shared<ReplayArgs>();
  auto* cmd = app.add_subcommand(
      "replay",
      "Re-send a capture's queries (lec --record, lec sniff, lec serve --record) to the twin or "
      "a port, and compare every reply with the captured one: bytes, decoded values, response "
      "time (docs/replay.md). Exit 0 when everything matched, 1 when something differed");
  cmd->add_option("FILE", a->file, "The capture (JSON Lines, docs/capture-format.md)")
      ->required()
      ->type_name("FILE");
  cmd->add_option("--against", a->against,
                  "Where to send: sim (the built-in twin, in virtual time: no waiting) or a port "
                  "(/dev/ttyUSB0, rtu+tcp://host:port), opened at --baud, which must be the "
                  "capture's")
      ->capture_default_str();
  cmd->add_option("--timing", a->timing,
                  "as-captured: each query ends at its captured offset from the first (the "
                  "controller acts at the captured instant); fast: each as soon as the previous "
                  "exchange is over")
      ->check(CLI::IsMember({"as-captured", "fast"}))
      ->capture_default_str();
  cmd->add_flag("--ideal", a->ideal,
                "With --against sim: the manual's ideal twin (lec sim --ideal) instead of the "
                "default twin; a --profile is read over it");
  cmd->add_option("--profile", a->profile,
                  "With --against sim: the twin's field profile (e.g. from lec sim --calibrate)")
      ->type_name("FILE");
  cmd->add_option("--report", a->report, "Also write the report as JSON to this file")
      ->type_name("FILE");
  cmd->add_option("--position-tolerance", a->position_tolerance_mm,
                  "Positions (D9000) sampled at the same elapsed time match within this, mm")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str();
  cmd->add_option("--response-tolerance", a->response_tolerance_pct,
                  "Response times match when the median of twin/captured, exchange by "
                  "exchange, is within this, %")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str();
  cmd->add_option("--edge-tolerance", a->edge_tolerance_ms,
                  "A flag (BUSY, INP, an output) that differs matches when the twin shows the "
                  "captured value at another exchange within this many ms: its edge fell on the "
                  "other side of a poll. 0: flags must agree exchange by exchange")
      ->check(CLI::Range(0.0, 60000.0))
      ->capture_default_str();
  cmd->callback([a, &globals] { run_replay_command(*a, globals); });
}

}  // namespace lec6::cli
