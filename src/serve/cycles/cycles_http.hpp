#pragma once
// The machine cycles' endpoints of lec serve's HTTP API (docs/api.md):
//
//   GET  /api/cycles                  every cycle: name, file, axes, running, last run
//   GET  /api/cycles/{name}           one of them
//   POST /api/cycles/{name}/run       runs it; answers with its report when it ends
//                                     (?wait=false: 202 now)
//   POST /api/cycles/{name}/stop      stops every axis of it; answers with its report
//
// Thread safety: as HttpApi's (the event loop); answers come from any thread.

#include <string>
#include <string_view>
#include <vector>

#include "cycles/cycle_service.hpp"
#include "http/http_server.hpp"

namespace lec6::serve {

// Answers a request whose path is /api/cycles[/...] (`parts`: its segments,
// "api" and "cycles" first). `cycles` null: lec serve runs none.
void handle_cycles_http(CycleService* cycles, const std::vector<std::string_view>& parts,
                        const HttpRequest& request, Responder& responder,
                        const std::string& source);

}  // namespace lec6::serve
