#pragma once
// Parsing of `lec sim`'s option values (private to cmd_sim.cpp).

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace lec6::cli::sim_args {

std::string trim(std::string s);
// "1", "1,2,3", "1-16", "1-4,9": sorted, without duplicates (UsageError otherwise).
std::vector<uint8_t> parse_ids(const std::string& text);
// 1-16 / 1, 3, 5-7: for the ready line.
std::string format_ids(const std::vector<uint8_t>& ids);
double parse_mm(const std::string& option, const std::string& text);
// HOST:PORT (HOST defaults to 127.0.0.1).
std::pair<std::string, uint16_t> parse_tcp(const std::string& text);

}  // namespace lec6::cli::sim_args
