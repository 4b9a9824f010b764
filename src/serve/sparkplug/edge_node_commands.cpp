// The edge node's DCMDs: checked (session.hpp, dcmd.hpp), run by Operations
// as the HTTP API's and the MQTT bridge's commands are, their outcome as metrics.

#include <fmt/format.h>

#include <algorithm>

#include "sparkplug/edge_node_core.hpp"

namespace lec6::serve {

using namespace sparkplug;

namespace {

// Operations refused it before anything reached the wire (ops/operations.hpp):
// bad arguments, the axis' state, the line down or the daemon stopping.
bool refused_before_the_wire(int status) {
  return status == 400 || status == 409 || status == 503;
}

}  // namespace

int64_t SparkplugNode::Core::number(std::size_t i) {
  return ++*numbered[i];
}

void SparkplugNode::Core::command(const DeviceCommand& c, uint64_t stops_seen) {
  const std::size_t i = c.device;
  // A command sent before a stop of its axis never runs after that stop.
  auto overtaken = [&] { return stops[i]->load() != stops_seen; };
  if (overtaken()) return refuse(i, "a stop sent after this DCMD came first: not run");
  std::vector<Write> writes;
  for (const Write& w : c.writes) {
    if (w.metric < command_offset) return refuse(i, "only Command/... metrics are writable");
    writes.push_back({w.metric - command_offset, w.value});
  }
  std::optional<Plan> plan_ok;
  std::string why;
  {
    std::lock_guard lock(mutex);
    auto p = plan(writes, commands[i].move);
    if (p) {
      plan_ok = std::move(*p);
    } else {
      why = p.error();
    }
  }
  if (!plan_ok) return refuse(i, why);
  Plan& p = *plan_ok;
  // Checked again as late as can be: a stop that came while this was planned wins.
  if (p.command && p.command->op != Op::Stop && overtaken())
    return refuse(i, "a stop sent after this DCMD came first: not run");
  const int64_t count = number(i);
  {
    // The settings are kept now and given back if Operations refuses the
    // action before the wire (finished()): a refused DCMD keeps nothing.
    std::lock_guard lock(mutex);
    CommandState& s = commands[i];
    s.count = std::max(s.count, count);
    record_settings(s, count, p.move);
    if (!p.command) settle_settings(s, count, false);  // settings alone: kept
    if (p.command) {
      s.outcome = "running";
      s.message = std::string(op_name(p.command->op)) + (p.note.empty() ? "" : ": " + p.note);
      s.status = 0;
    } else {
      s.outcome = "set";
      s.message = "move settings kept";
      s.status = 200;
    }
  }
  if (p.command) {
    const bool is_stop = p.command->op == Op::Stop;
    ops.run(axes[i], *p.command, "sparkplug DCMD",
            [weak = weak_from_this(), i, count, is_stop](OpResult r) {
              if (auto self = weak.lock()) self->finished(i, count, r, is_stop);
            });
  }
  log(LogLevel::Info, fmt::format("sparkplug: DCMD for {}: {}{}", axes[i].name,
                                  p.command ? op_name(p.command->op) : "move settings",
                                  p.note.empty() ? "" : " (" + p.note + ")"));
  std::lock_guard lock(mutex);
  sample_axis(i, sparkplug_unix_ms());
}

// The stop goes to Operations (the emergency lane) before any lock is taken;
// its number is an atomic's, so even a result that comes back at once is its own.
void SparkplugNode::Core::stop_now(std::size_t i) {
  const int64_t count = number(i);
  Command stop;
  stop.op = Op::Stop;
  ++*stops[i];  // DCMDs received before it and not yet handled will not run after it
  ops.run(axes[i], stop, "sparkplug DCMD", [weak = weak_from_this(), i, count](OpResult r) {
    if (auto self = weak.lock()) self->finished(i, count, r, true);
  });
  log(LogLevel::Info, fmt::format("sparkplug: DCMD for {}: stop", axes[i].name));
  CpuSpan cpu(cpu_ns);
  std::lock_guard lock(mutex);
  CommandState& s = commands[i];
  if (count > s.count) {  // not already finished, nor overtaken by a later DCMD
    s.count = count;
    s.outcome = "running";
    s.message = "stop";
    s.status = 0;
  }
  if (count > s.stop_count) {
    s.stop_count = count;
    s.stop_outcome = "running";
    s.stop_message = "stop";
  }
  sample_axis(i, sparkplug_unix_ms());
}

void SparkplugNode::Core::refuse(std::size_t i, const std::string& why) {
  log(LogLevel::Warning, fmt::format("sparkplug: DCMD for {} refused: {}", axes[i].name, why));
  const int64_t count = number(i);
  std::lock_guard lock(mutex);
  CommandState& s = commands[i];
  if (count < s.count) return;
  s.count = count;
  s.outcome = "refused";
  s.message = why;
  s.status = 400;
  sample_axis(i, sparkplug_unix_ms());
}

// From an operation's thread: the result as metrics, unless a later DCMD has
// taken the device's command state since.
void SparkplugNode::Core::finished(std::size_t i, int64_t count, const OpResult& r, bool stop) {
  if (stopped) return;
  std::lock_guard lock(mutex);
  CommandState& s = commands[i];
  settle_settings(s, count, refused_before_the_wire(r.status));
  const std::string outcome = r.status == 200 ? "done" : "failed";
  const std::string message = r.body.value("message", r.body.value("error", std::string()));
  if (count >= s.count) {
    s.count = count;
    s.outcome = outcome;
    s.status = r.status;
    s.message = message;
  }
  if (stop && count >= s.stop_count) {
    s.stop_count = count;
    s.stop_outcome = outcome;
    s.stop_message = message;
  }
  sample_axis(i, sparkplug_unix_ms());
}

}  // namespace lec6::serve
