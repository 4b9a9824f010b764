#pragma once
// How controller data look to people and to machines, shared by commands.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "lec6/lec/alarms.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/lec/state_data.hpp"

namespace lec6::cli {

nlohmann::json flags_json(const lec::StatusFlags& f);
nlohmann::json state_json(const lec::StateData& s, const lec::StatusFlags& f,
                          const std::vector<uint8_t>& alarms);
// "  150.00 mm   500 mm/s  thrust  12 %  BUSY SVRE" for a progress line.
std::string progress_line(const lec::StateData& s, const lec::StatusFlags& f);
nlohmann::json alarm_json(uint8_t code);

}  // namespace lec6::cli
