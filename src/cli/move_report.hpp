#pragma once
// How `lec move`, `lec home` and `lec follow` report a move: one line in the
// manual's words (MoveResult::describe), JSON with the outcome and the
// timeline, and an exit code that follows the outcome.

#include <functional>
#include <nlohmann/json.hpp>

#include "cli/app.hpp"
#include "lec6/client/move_result.hpp"

namespace lec6::cli {

// reached, pushed 0; push missed, stopped, not started 1; alarm 5;
// deadline 6; stopped by Ctrl-C 130.
int exit_code(const client::MoveResult& r);

// The state with "outcome", "message", "goal", "timeline" {start_ms: 0,
// busy_up_ms, busy_down_ms, inp_ms} (null when not seen), "evidence".
nlohmann::json move_json(const client::MoveResult& r);

// Prints the result (one line, or JSON) and throws CommandFailed when the
// outcome is not a success.
void report_move(const Session& s, const client::MoveResult& r);

// Runs a move; when it ends in an error that carries a MoveResult (alarm,
// deadline, not started, Ctrl-C), prints that result as JSON first (--json),
// then lets the error go on to main() for its message and exit code.
void with_move_report(const Session& s, const std::function<void()>& run);

}  // namespace lec6::cli
