// The edge node's DCMDs: checked (session.hpp, dcmd.hpp), run by Operations
// as the HTTP API's and the MQTT bridge's commands are, their outcome as metrics.

#include <fmt/format.h>

#include "sparkplug/edge_node_core.hpp"

namespace lec6::serve {

using namespace sparkplug;

void SparkplugNode::Core::command(const DeviceCommand& c) {
  const std::size_t i = c.device;
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
  // A stop runs before anything is published or logged.
  int64_t count = 0;
  if (p.command) {
    std::lock_guard lock(mutex);
    CommandState& s = commands[i];
    count = ++s.count;
    s.outcome = "running";
    s.message = std::string(op_name(p.command->op)) + (p.note.empty() ? "" : ": " + p.note);
    s.status = 0;
  }
  if (p.command) {
    ops.run(axes[i], *p.command, "sparkplug DCMD", [weak = weak_from_this(), i, count](OpResult r) {
      if (auto self = weak.lock()) self->finished(i, count, r);
    });
  }
  log(LogLevel::Info, fmt::format("sparkplug: DCMD for {}: {}{}", axes[i].name,
                                  p.command ? op_name(p.command->op) : "move settings",
                                  p.note.empty() ? "" : " (" + p.note + ")"));
  std::lock_guard lock(mutex);
  CommandState& s = commands[i];
  s.move = p.move;
  if (!p.command) {
    ++s.count;
    s.outcome = "set";
    s.message = "move settings kept";
    s.status = 200;
  }
  sample_axis(i, sparkplug_unix_ms());
}

void SparkplugNode::Core::refuse(std::size_t i, const std::string& why) {
  log(LogLevel::Warning, fmt::format("sparkplug: DCMD for {} refused: {}", axes[i].name, why));
  std::lock_guard lock(mutex);
  CommandState& s = commands[i];
  ++s.count;
  s.outcome = "refused";
  s.message = why;
  s.status = 400;
  sample_axis(i, sparkplug_unix_ms());
}

// From an operation's thread: the result as metrics, unless a later DCMD has
// taken the device's command state since.
void SparkplugNode::Core::finished(std::size_t i, int64_t count, const OpResult& r) {
  if (stopped) return;
  std::lock_guard lock(mutex);
  CommandState& s = commands[i];
  if (s.count != count) return;
  s.outcome = r.status == 200 ? "done" : "failed";
  s.status = r.status;
  s.message = r.body.value("message", r.body.value("error", std::string()));
  sample_axis(i, sparkplug_unix_ms());
}

}  // namespace lec6::serve
