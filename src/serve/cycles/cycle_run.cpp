#include "cycles/cycle_run.hpp"

#include <algorithm>
#include <memory>
#include <vector>

#include "lec6/client/client.hpp"
#include "lec6/cycle/analysis.hpp"
#include "lec6/cycle/report_json.hpp"
#include "lec6/cycle/runner.hpp"
#include "line/line_master.hpp"

namespace lec6::serve {

OpResult run_served_cycle(const ServedCycle& served, const std::map<std::string, AxisRef>& axes,
                          const Operations::Claim& claim, const std::function<bool()>& asked) {
  // One master per line: the cycle's axes on a line share it (its commands
  // keep their order and take turns with other clients'), as they share the
  // port under `lec cycle run`.
  std::map<Line*, std::unique_ptr<LineMaster>> masters;
  std::vector<std::unique_ptr<client::Client>> clients;
  std::map<std::string, client::Client*> by_name;
  client::StopPolicy policy;
  policy.escalate_servo_off = true;  // only when every axis says so
  for (const cycle::Axis& a : served.cycle.axes) {
    const AxisRef& ref = axes.at(a.name);
    auto& master = masters[ref.line];
    if (!master) {
      master = std::make_unique<LineMaster>(*ref.line, Priority::Completion, Priority::Command);
      master->count_from(claim.accepted);
    }
    client::ClientOptions co;
    co.id = ref.id;
    co.retries = ref.line_config->retries;
    co.alarm_polarity = ref.config->alarm_polarity;
    clients.push_back(std::make_unique<client::Client>(*master, co));
    by_name[a.name] = clients.back().get();
    policy.escalate_servo_off = policy.escalate_servo_off && ref.config->stop_servo_off;
  }
  // A hard stop to any of the cycle's controllers on a line refuses the
  // cycle's starts to the others there, queued or later (Job::stop_group).
  // Across lines, the cycle's next look sees it.
  for (auto& [line, master] : masters) {
    std::vector<uint8_t> ids;
    for (const cycle::Axis& a : served.cycle.axes)
      if (axes.at(a.name).line == line) ids.push_back(axes.at(a.name).id);
    master->stop_group(std::move(ids));
  }
  // A stop seen: asked for, through the operations (or a shutdown, seen by
  // the operations or by a line that takes only stops now), or a hard stop
  // to one of the cycle's controllers accepted by its line since the cycle
  // was (a Modbus TCP client's).
  // lec serve shuts down: a line of the cycle takes only stops now.
  const auto shutting_down = [&] {
    return std::any_of(axes.begin(), axes.end(),
                       [](const auto& a) { return a.second.line->stopping(); });
  };
  const auto stop_seen = [&] {
    if (asked() || claim.stopped() || shutting_down()) return true;
    for (const auto& [name, ref] : axes) {
      const auto at = ref.line->last_hard_stop(ref.id);
      if (at && *at >= claim.accepted) return true;
    }
    return false;
  };
  cycle::RunOptions options;
  options.stop_policy = policy;
  // Only lec serve's shutdown fails the cycle's exchanges for a stop (a
  // stop of an axis or of the cycle fails none): any other failure is the
  // line's (a reviewer's finding: a real fault, relabelled a stop, left the
  // axes free although none was seen at rest).
  options.failure_is_stop = shutting_down;
  options.stop_requested = [&] {
    // The times first, then the look: a stop accepted after these times
    // supersedes the starts that follow (their writes carry them); one
    // accepted before was seen here (the operations and the line date a
    // stop under the lock this look takes).
    std::vector<std::pair<LineMaster*, TimePoint>> looked;
    for (auto& [line, master] : masters) looked.emplace_back(master.get(), line->clock().now());
    if (stop_seen()) {
      // The runner stops every axis now and reads each until it is at rest:
      // those reads go at Emergency, as an operation's stop's do.
      for (auto& [line, master] : masters) master->reads_urgent();
      return true;
    }
    for (auto& [master, at] : looked) master->count_from(at);
    return false;
  };
  cycle::Runner runner(served.cycle, by_name, options);
  const cycle::CycleReport report = runner.run();
  OpResult result;
  result.body = nlohmann::json::parse(
      cycle::report_json(served.name(), report, cycle::analyse(report), /*simulated=*/false));
  const bool line_fault = report.ended.rfind("line fault", 0) == 0;
  // An axis the stop could not see at rest: 502 like a line fault, so its
  // motion slot stays taken until a read shows BUSY = 0 (unsettled).
  const bool unseen = std::any_of(report.stood.begin(), report.stood.end(),
                                  [](const auto& s) { return !s.stopped; });
  result.status = report.completed ? 200 : (line_fault || unseen) ? 502 : 422;
  if (!report.completed) result.body["error"] = report.ended;
  return result;
}

}  // namespace lec6::serve
