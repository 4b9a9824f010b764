#pragma once
// Machine cycles inside lec serve (issue 34; docs/cycles.md, "Through lec
// serve"; the HTTP endpoints: cycles_http.hpp). A cycle runs on lec serve's
// own lines: the library's cycle::Runner over LineMasters, so its exchanges
// queue on each line's scheduler like any client's (reads at
// Priority::Completion, writes at Priority::Command, stops at Emergency).
//
// Rules:
//   - a cycle holds the motion slot of every one of its axes while it runs
//     (Operations::run_claimed): it is refused (409) when one of them is
//     busy or may still be moving, and another motion of them is refused
//     (409, naming the cycle) until it has ended; one run of a cycle at a
//     time;
//   - a stop ends it: a stop, hold, reset or servo off of one of its axes accepted
//     through lec serve's operations (HTTP, MQTT, Sparkplug, the dashboard),
//     a hard stop (RESET <- 1, HOLD <- 1, SVON <- 0) to one of its
//     controllers from any client of the line (Modbus TCP, RTU over TCP),
//     POST /api/cycles/{name}/stop (a stop of each of its axes through the
//     operations), or lec serve shutting down. The runner then stops every
//     axis of the cycle (a RESET pulse each, judged by the axis:
//     client/stop.hpp, with lec serve's stop_servo_off when every axis has
//     it) and the report says where each stood;
//   - no motion starts after a stop accepted while the cycle runs: the
//     cycle's writes carry the time of its last look for stops
//     (LineMaster::count_from), so a stop accepted after that look
//     supersedes its starts on the line (docs/protocol-decisions.md, "A stop
//     supersedes"), and one accepted before it was seen by it.
//
// Thread safety: every public member may be called from any thread.

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "cycles/served_cycle.hpp"
#include "lec6/serve/log.hpp"
#include "ops/axis_directory.hpp"
#include "ops/operations.hpp"

namespace lec6::serve {

class CycleService {
 public:
  // Throws InvalidArgument when a cycle's axis is not in `directory` (the
  // config was read against another one).
  CycleService(const AxisDirectory& directory, Operations& ops,
               std::vector<std::shared_ptr<const ServedCycle>> cycles, Log log);
  CycleService(const CycleService&) = delete;
  CycleService& operator=(const CycleService&) = delete;

  // GET /api/cycles: each cycle's name, file, axes, whether it runs, its last run.
  nlohmann::json list() const;
  // One of them; nullopt: no cycle of that name.
  std::optional<nlohmann::json> describe(std::string_view name) const;
  // Runs the cycle; `done` gets the report (cycle/report_json.hpp) when it
  // ends: 200 completed, 422 stopped or aborted, 502 a line fault; or a
  // refusal (404 unknown, 409 busy, 503 shutting down).
  void run(std::string_view name, std::string source, std::function<void(OpResult)> done);
  // Stops every axis of the running cycle through the operations; `done`
  // gets the cycle's report once it has ended, with each stop's result
  // (404 unknown, 409 not running).
  void stop(std::string_view name, std::string source, std::function<void(OpResult)> done);

 private:
  struct State;
  nlohmann::json state_json(const State& s) const;

  const AxisDirectory& directory_;
  Operations& ops_;
  Log log_;
  mutable std::mutex mutex_;
  std::map<std::string, std::shared_ptr<State>, std::less<>> states_;
};

}  // namespace lec6::serve
