#pragma once
// Shared by the serve fuzz-harness tests (http, mbap): property violations
// thrown instead of aborting, and the inputs kept under
// tests/fuzz_regressions/<harness>/.

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "../../fuzz/harness.hpp"

namespace lec6::fuzz {

// While alive, a violated property throws std::runtime_error.
struct ThrowOnFailure {
  ThrowOnFailure() {
    failure_handler() = [](const std::string& what) { throw std::runtime_error(what); };
  }
  ~ThrowOnFailure() { failure_handler() = nullptr; }
};

// Every kept input of `harness` as (file name, bytes); dot files are skipped.
inline std::vector<std::pair<std::string, std::string>> kept_inputs(const std::string& harness) {
  const auto dir = std::filesystem::path(LEC6_TEST_DATA_DIR) / ".." / "fuzz_regressions" / harness;
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_regular_file() || name.starts_with(".")) continue;
    std::ifstream in(entry.path(), std::ios::binary);
    std::ostringstream bytes;
    bytes << in.rdbuf();
    out.emplace_back(name, bytes.str());
  }
  return out;
}

}  // namespace lec6::fuzz
