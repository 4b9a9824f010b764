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
  const char* kOvertaken = "a stop sent after this DCMD came first: not run";
  if (overtaken()) return refuse(i, kOvertaken);
  std::vector<Write> writes;
  for (const Write& w : c.writes) {
    if (w.metric < command_offset) return refuse(i, "only Command/... metrics are writable");
    writes.push_back({w.metric - command_offset, w.value});
  }
  const int64_t count = number(i);
  std::optional<Command> action;
  std::string note;
  {
    // Planned on the settings as they are and recorded in one go: a result
    // that comes back meanwhile cannot be undone by a stale plan. The
    // settings are kept now and given back if Operations refuses the action
    // before the wire (finished()): a refused DCMD keeps nothing.
    std::lock_guard lock(mutex);
    CommandState& s = commands[i];
    auto p = plan(writes, s.move);
    if (!p) return refuse_locked(i, count, p.error());
    if (p->command && p->command->op != Op::Stop && overtaken())
      return refuse_locked(i, count, kOvertaken);
    record_settings(s, count, *p);
    if (!p->command) settle_settings(s, count, false);  // settings alone: kept
    if (count >= s.count) {  // not overtaken by a later DCMD's (a stop's) result
      s.count = count;
      if (p->command) {
        s.outcome = "running";
        s.message = std::string(op_name(p->command->op)) + (p->note.empty() ? "" : ": " + p->note);
        s.status = 0;
      } else {
        s.outcome = "set";
        s.message = "move settings kept";
        s.status = 200;
      }
    }
    action = std::move(p->command);
    note = std::move(p->note);
  }
  if (action) {
    const bool is_stop = action->op == Op::Stop;
    ops.run(axes[i], *action, "sparkplug DCMD",
            [weak = weak_from_this(), i, count, is_stop](OpResult r) {
              if (auto self = weak.lock()) self->finished(i, count, r, is_stop);
            });
    // A stop that came between the last check and the run above went to the
    // line first and found nothing to stop: stop again (a stop is idempotent).
    if (!is_stop && overtaken()) {
      log(LogLevel::Warning,
          fmt::format("sparkplug: DCMD for {}: a {} raced a stop sent after it: stopping again",
                      axes[i].name, op_name(action->op)));
      stop_now(i);
    }
  }
  log(LogLevel::Info, fmt::format("sparkplug: DCMD for {}: {}{}", axes[i].name,
                                  action ? op_name(action->op) : "move settings",
                                  note.empty() ? "" : " (" + note + ")"));
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
  const int64_t count = number(i);
  std::lock_guard lock(mutex);
  refuse_locked(i, count, why);
}

void SparkplugNode::Core::refuse_locked(std::size_t i, int64_t count, const std::string& why) {
  log(LogLevel::Warning, fmt::format("sparkplug: DCMD for {} refused: {}", axes[i].name, why));
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
