// docs/twin-fidelity.md names, for every behaviour of the twin, the code that
// implements it as `file#symbol`. This keeps the ledger honest: every row has
// a code reference, every named file exists, and every named symbol is still
// in it. Rename or move the code and this fails until the ledger follows.

#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

namespace {

const std::string kRepo = std::string(LEC6_TEST_DATA_DIR) + "/../..";

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return {};
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(FidelityLedger, EveryRowNamesCodeThatExists) {
  const std::string ledger = slurp(kRepo + "/docs/twin-fidelity.md");
  ASSERT_FALSE(ledger.empty()) << "docs/twin-fidelity.md is missing";
  const std::regex row(R"(^\| (R-[A-Z0-9-]+) \|)");
  const std::regex ref(R"(`((?:src|include)/[A-Za-z0-9_./-]+)#([^`]+)`)");
  std::istringstream lines(ledger);
  std::string line;
  std::set<std::string> ids;
  int rows = 0;
  while (std::getline(lines, line)) {
    std::smatch m;
    if (!std::regex_search(line, m, row)) continue;
    ++rows;
    const std::string id = m[1];
    EXPECT_TRUE(ids.insert(id).second) << id << " appears twice";
    int refs = 0;
    for (auto it = std::sregex_iterator(line.begin(), line.end(), ref); it != std::sregex_iterator();
         ++it) {
      ++refs;
      const std::string file = (*it)[1];
      const std::string symbol = (*it)[2];
      const std::string text = slurp(kRepo + "/" + file);
      ASSERT_FALSE(text.empty()) << id << ": " << file << " does not exist";
      EXPECT_NE(text.find(symbol), std::string::npos)
          << id << ": '" << symbol << "' is no longer in " << file;
    }
    EXPECT_GT(refs, 0) << id << " names no code (`file#symbol`)";
  }
  EXPECT_GE(rows, 30) << "the ledger lost rows";
}

// The twin's decisions point back at the ledger.
TEST(FidelityLedger, TheTwinsSourcesPointAtIt) {
  for (const char* file : {"include/lec6/sim/behaviour.hpp", "src/sim/controller.cpp",
                           "src/sim/controller_operations.cpp", "src/sim/bus.cpp",
                           "src/lec/step_data.cpp"}) {
    EXPECT_NE(slurp(kRepo + "/" + file).find("docs/twin-fidelity.md"), std::string::npos)
        << file << " does not mention docs/twin-fidelity.md";
  }
}

}  // namespace
