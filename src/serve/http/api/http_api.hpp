#pragma once
// lec serve's HTTP API (docs/api.md has an example per endpoint):
//
//   GET  /api/lines                         lines, settings, stats
//   GET  /api/axes                          every axis from the cache
//   GET  /api/axes/{name}                   one axis: state, flags, inputs, alarms, health,
//                                           the operation under way, the last result
//   POST /api/axes/{name}/{op}              serial servo home move run-step jog jog-stop
//                                           hold stop reset (commands.hpp); a move answers
//                                           with its outcome when it ends (?wait=false: 202 now)
//   GET  /api/axes/{name}/steps[?format=csv|json]   the 64 steps (a backup)
//   GET  /api/axes/{name}/steps/{n}         one step
//   PUT  /api/axes/{name}/steps/{n}         change fields of one step (only changed registers)
//   POST /api/axes/{name}/steps/plan        a backup file (CSV or JSON): what a restore would
//                                           write, nothing written; bad rows: 400 with every error
//   POST /api/axes/{name}/steps[?dry_run=1] restore it: only differing steps written, read back
//   GET  /api/axes/{name}/alarms            active alarms and the 16-group history
//   GET  /api/axes/{name}/history           recorded motions (filters, paging, CSV), and
//   GET  /api/axes/{name}/health            odometer, drift warnings (history/history_http.hpp)
//   GET  /api/lines/{line}/twin             the built-in twin's settings (sim lines)
//   POST /api/lines/{line}/twin             change them: workpiece, fault rates
//   GET  /api/cycles[/{name}]               machine cycles (issue 34: cycles/cycles_http.hpp)
//   POST /api/cycles/{name}/run|stop        runs or stops one; answers with its report
//   GET  /api/fields                        the step fields: ranges, defaults, rules
//   GET  /api/events                        Server-Sent Events: hello, telemetry, op, stats,
//                                           history, drift, health
//   GET  /metrics                           Prometheus text
//   GET  /…                                 the dashboard's files
//
// Writes follow http_auth.hpp (token beyond loopback, read-only listeners).
//
// Thread safety: handle() runs on the event loop; observers on line threads.

#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "http/http_server.hpp"
#include "http/static_files.hpp"
#include "line/line.hpp"
#include "ops/axis_directory.hpp"
#include "ops/operations.hpp"

namespace lec6::serve {

class CycleService;

// The open /api/events streams, fed from any thread.
class EventHub {
 public:
  void add(EventStream stream);
  // Sends to every open stream; drops the closed ones.
  void broadcast(std::string_view event, const std::string& data,
                 EventStream::Delivery delivery = EventStream::Delivery::Droppable);
  std::size_t size() const;

 private:
  mutable std::mutex mutex_;
  std::vector<EventStream> streams_;
};

class HttpApi {
 public:
  // `directory`: the axes and lines it serves (the daemon's, or a test's).
  // `cycles`: the machine cycles it offers (/api/cycles); null: none.
  HttpApi(const AxisDirectory& directory, Operations& ops, const HttpConfig& config, Log log,
          CycleService* cycles = nullptr);

  void handle(HttpRequest request, Responder responder);
  EventHub& events() noexcept { return events_; }
  // The stats event, once a second (the daemon's timer calls it).
  void publish_stats();

 private:
  void route_axis(const AxisRef& axis, std::vector<std::string_view> rest, HttpRequest& request,
                  Responder& responder);
  void command(const AxisRef& axis, std::string_view op, HttpRequest& request,
               Responder& responder);
  void steps(const AxisRef& axis, std::vector<std::string_view> rest, HttpRequest& request,
             Responder& responder);
  void twin(std::string_view line, HttpRequest& request, Responder& responder);
  void open_events(Responder& responder);
  std::string source(const HttpRequest& request) const;

  const AxisDirectory& directory_;
  Operations& ops_;
  CycleService* cycles_ = nullptr;
  HttpConfig config_;
  Log log_;
  std::unique_ptr<StaticFiles> files_;
  EventHub events_;
  std::atomic<uint64_t> next_stream_{1};
  std::mutex streams_mutex_;
  std::map<uint64_t, EventStream> streams_by_id_;  // by the id of their hello event
};

// Where the dashboard's files are: http.web_root when set, else beside the
// binary (build tree: <dir of lec>/web; installed: <prefix>/share/lec6/web).
std::filesystem::path default_web_root();

}  // namespace lec6::serve
