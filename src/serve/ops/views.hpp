#pragma once
// The daemon's state as JSON for the HTTP API, the dashboard's stream and the
// MQTT bridge, with the CLI's `--json` keys (position_mm, speed_mm_s,
// thrust_pct, target_mm, step, flags, alarms) so one parser reads them all.
// Built from the telemetry cache: reading them costs the line nothing.
//
// Thread safety: pure functions over thread-safe snapshots.

#include <string>

#include <nlohmann/json.hpp>

#include "lec6/serve/daemon.hpp"
#include "line/line.hpp"
#include "ops/operations.hpp"

namespace lec6::serve {

// One axis: state, flags, inputs, alarms, communication health, and the
// operation under way / the last one's result (when `ops` is given).
nlohmann::json axis_json(const AxisRef& axis, const Operations* ops = nullptr);
// The compact form streamed many times a second: state, flags, health.
nlohmann::json telemetry_json(const AxisRef& axis, const AxisSnapshot& snapshot);
// One line: port, settings, axes, stats.
nlohmann::json line_json(const LineConfig& config, const Line& line);
// The stats of a line, for the bus page.
nlohmann::json stats_json(const LineStatsSnapshot& s, const LineConfig& config);

// The step fields with the manual's ranges, the defaults a blank step starts
// from and the rules between fields, so a page validates as the user types
// from the same table the daemon checks (lec::step_fields()).
nlohmann::json step_fields_json();

// Prometheus text exposition of every line's stats (GET /metrics).
std::string prometheus_metrics(const Daemon& daemon);

}  // namespace lec6::serve
