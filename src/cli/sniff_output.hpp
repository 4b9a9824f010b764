#pragma once
// `lec sniff`'s output: one line per frame (text, coloured on a terminal, or
// JSON), the --filter, and the statistics table.

#include <string>
#include <vector>

#include "lec6/clock.hpp"
#include "lec6/modbus/sniffer.hpp"
#include "lec6/modbus/timing.hpp"

namespace lec6::cli {

// "late, short-silence" (empty when no flag is set).
std::string flag_words(const modbus::SniffEvent& e);

// --filter "id=1,2 fn=3 addr=9000-9010" (terms separated by spaces or ';',
// values by ','). Throws UsageError naming the bad term.
class SniffFilter {
 public:
  static SniffFilter parse(const std::string& text);
  bool passes(const modbus::SniffEvent& e) const;

 private:
  std::vector<std::pair<unsigned, unsigned>> ids_, functions_;
  std::optional<std::pair<unsigned, unsigned>> addresses_;
};

class SniffPrinter {
 public:
  SniffPrinter(bool json, TimePoint origin, const modbus::LineTiming& timing);
  void notice(const std::string& text);  // stderr, prefixed "lec sniff: "
  void event(const modbus::SniffEvent& e);
  void stats(const modbus::SniffStats& s, const modbus::SnifferOptions& options);

 private:
  bool json_;
  bool colour_;
  TimePoint origin_;
  modbus::LineTiming timing_;
};

}  // namespace lec6::cli
