#pragma once
// What the front-ends (the HTTP API, the MQTT bridge, /metrics) need of the
// daemon: its axes by name, its lines by name, and the move history. The
// daemon provides one (daemon.cpp); a test gives its own over a twin line
// (tests/serve/ops/twin_directory.hpp), so a front-end is tested without a
// daemon, its listeners or a socket.
//
// Thread safety: set up before any front-end starts and unchanged until they
// have stopped; read from any thread.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "lec6/serve/config.hpp"

namespace lec6::serve {

class Line;
namespace history {
class History;
}

// An axis of the daemon, by name.
struct AxisRef {
  std::string name;
  uint8_t id = 1;
  Line* line = nullptr;
  const LineConfig* line_config = nullptr;
  const AxisConfig* config = nullptr;
};

class AxisDirectory {
 public:
  virtual ~AxisDirectory() = default;

  // Every axis, in the configured order.
  virtual const std::vector<AxisRef>& axes() const = 0;
  // Every line as configured, in order.
  virtual const std::vector<LineConfig>& lines() const = 0;
  // The line called `name`; null when there is none.
  virtual Line* line(std::string_view name) const = 0;
  // The move history (issue 26) when configured; else null.
  virtual history::History* history() const = 0;

  // The axis called `name`; null when there is none.
  const AxisRef* axis(std::string_view name) const {
    for (const AxisRef& a : axes()) {
      if (a.name == name) return &a;
    }
    return nullptr;
  }
};

}  // namespace lec6::serve
