#pragma once
// What lec serve's edge node publishes (docs/sparkplug.md lists every
// metric): the node's metrics (version, each line's state and statistics)
// and each axis' as a device (state, flags, inputs, alarms with meanings,
// health, the operation under way and the last one's result, the move
// history's health and odometer when it is on, the commands' outcome, and
// the writable command metrics of dcmd.hpp). The values come from the same
// JSON the HTTP API and the MQTT bridge serve (ops/views.hpp).
//
// integration.sparkplug_host checks the births carry them (history ones included).
//
// Thread safety: pure functions.

#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include "lec6/serve/config.hpp"
#include "line/line_stats.hpp"
#include "sparkplug/dcmd.hpp"
#include "sparkplug/session.hpp"

namespace lec6::serve::sparkplug {

// The node's metrics for these lines (besides bdSeq and Node Control/Rebirth).
std::vector<MetricDef> node_metrics(const std::vector<LineConfig>& lines);
// One line's state for node_values(): "up" or "down: why", and its statistics.
struct LineNow {
  std::string state;
  LineStatsSnapshot stats;
};
std::vector<Value> node_values(const std::vector<LineNow>& lines);

// An axis' metrics; `history`: the move history is on (History/... metrics).
std::vector<MetricDef> axis_metrics(bool history);

struct AxisNow {
  nlohmann::json telemetry;                  // telemetry_json()
  std::optional<nlohmann::json> health;      // the move history's health of the axis
  const std::string* health_text = nullptr;  // health, dumped (once per refresh, not per sample)
  std::string running;                       // the operation under way ("" when none)
  std::optional<nlohmann::json> last;        // the last operation's result
  const CommandState* command = nullptr;
};
std::vector<Value> axis_values(const AxisNow& now, bool history);

}  // namespace lec6::serve::sparkplug
