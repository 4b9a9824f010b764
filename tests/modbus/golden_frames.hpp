#pragma once
// The golden frames of tests/data/manual-frames.tsv (copied from the shared
// conformance set), read from the file, so every row in it is tested.

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "lec6/modbus/pdu.hpp"

namespace lec6::testing {

struct GoldenFrame {
  std::string section;
  bool query;
  modbus::Bytes bytes;
  std::string meaning;
};

inline std::vector<GoldenFrame> load_golden_frames() {
  std::ifstream in(std::string(LEC6_TEST_DATA_DIR) + "/manual-frames.tsv");
  std::vector<GoldenFrame> out;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    GoldenFrame g;
    std::string kind, hex;
    std::getline(fields, g.section, '\t');
    std::getline(fields, kind, '\t');
    std::getline(fields, hex, '\t');
    std::getline(fields, g.meaning);
    g.query = kind == "query";
    g.bytes = *modbus::from_hex(hex);
    out.push_back(std::move(g));
  }
  return out;
}

}  // namespace lec6::testing
