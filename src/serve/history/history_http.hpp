#pragma once
// The history's part of the HTTP API (docs/api.md):
//
//   GET  /api/axes/{name}/history   records, newest first; filters: since, until (ISO 8601
//                                   UTC or a date), kind, outcome, source, step; paging:
//                                   limit (1 to 10000, default 100), before (a record id);
//                                   format=csv for CSV. A bad filter: 400 naming it.
//   GET  /api/axes/{name}/health    odometer, service notices, drift warnings, groups
//                                   (?trend=1: each group's recent moves, for a plot)
//   POST /api/axes/{name}/health/service   {"what": "lubricate"}: the service is done
//
// Thread safety: as HttpApi (the event loop).

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "http/http.hpp"
#include "http/http_server.hpp"
#include "lec6/serve/daemon.hpp"
#include "line/line.hpp"
#include "store.hpp"

namespace lec6::serve::history {

class History;

// Answers the request when `rest` (the path after /api/axes/{name}) is one
// of the history's; false: not one of them (the caller routes it on).
bool handle_http(History* history, const AxisRef& axis, const std::vector<std::string_view>& rest,
                 const HttpRequest& request, Responder& responder);

// The query of GET …/history; an error names the parameter (sans-I/O, tested).
struct QueryError {
  std::string parameter, message;
};
std::variant<HistoryQuery, QueryError> parse_query(const std::string& axis,
                                                   const std::map<std::string, std::string>& q);
// "2026-11-24T10:00:00Z", "2026-11-24T10:00:00.250Z", "2026-11-24" → Unix ms.
std::optional<int64_t> parse_time(std::string_view text);

}  // namespace lec6::serve::history
