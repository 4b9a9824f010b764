#pragma once
// `--json` output: nlohmann::json trees printed as nlohmann prints them, with
// one rule of our own. Keys carry units (position_mm, speed_mm_s, thrust_pct,
// README "--json"); a number under a key in millimetres (`..._mm`) prints with
// the two decimals of the manual (150.00, -0.50), where nlohmann's shortest
// form would print 150.0. The tree holds plain numbers: the rule lives in the
// printer, so every key in millimetres is printed alike.

#include <cstdint>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace lec6::cli {

// A length in 0.01 mm as a JSON number in millimetres (15000 → 150.0, printed 150.00).
nlohmann::json mm_json(int64_t value_001mm);

// Does a key name a value in millimetres?
bool is_mm_key(std::string_view key);

// The JSON text: nlohmann's layout (`indent` < 0: one line; else that many
// spaces per level), invalid UTF-8 replaced, numbers under `_mm` keys with two decimals.
std::string dump_json(const nlohmann::json& j, int indent = -1);

// dump_json(j, 2) and a newline, on stdout.
void print_json(const nlohmann::json& j);

}  // namespace lec6::cli
