#pragma once
// What a motion command asked, for the "started" event of operations.hpp
// (the history groups comparable moves by it): step, target and the direct
// move's speed, acceleration and forces, in the API's keys.

#include <nlohmann/json.hpp>

#include "ops/commands.hpp"

namespace lec6::serve::history {

nlohmann::json motion_settings(const Command& cmd);

}  // namespace lec6::serve::history
