#pragma once
// Operation results as the HTTP API and MQTT give them (private to serve/):
// JSON in the manual's words, with an HTTP-style status (operations.hpp).

#include <exception>
#include <map>
#include <string>

#include "lec6/client/actuator.hpp"
#include "lec6/lec/alarm_check.hpp"
#include "lec6/lec/step_table.hpp"
#include "ops/commands.hpp"
#include "ops/operations.hpp"

namespace lec6::serve {

OpResult refusal(int status, const std::string& message, const std::string& field = {});
OpResult done_result(Op op, const std::string& message);
OpResult move_result(Op op, const client::MoveResult& r, bool stopped_by_other);
OpResult jog_result(const client::MoveResult& r, bool lease_expired, bool stream_closed);
// A RESET's answer: 422 with lec::alarm_after_reset's words when alarms stay.
OpResult reset_result(const std::vector<uint8_t>& still_active, lec::AlarmPolarity polarity);
OpResult step_read_result(unsigned step, const lec::StepData& data);
OpResult table_result(const lec::StepTable& table);
// Reads the step, changes the given fields, checks the whole record, and
// writes only the registers that differ (read back to verify).
OpResult step_write(client::Client& c, unsigned step,
                    const std::map<lec::StepField, int64_t>& fields);
// What an exception thrown by an operation means to the caller.
OpResult result_of(std::exception_ptr e, bool stopped_by_other);

nlohmann::json step_json(const lec::StepData& data);

}  // namespace lec6::serve
