// `lec serve --record` never truncates an earlier capture (issue 33): the
// file is moved aside to the first free PATH.N before a new one is written.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "lec6/transport/capture_file.hpp"

namespace lec6::transport {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(KeepEarlierCapture, MovesAnEarlierCaptureToTheFirstFreeNumber) {
  const fs::path dir =
      fs::temp_directory_path() / fs::path("lec6-rotate-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string path = (dir / "line.jsonl").string();
  EXPECT_FALSE(keep_earlier_capture(path)) << "nothing there: nothing kept";
  std::ofstream(path) << "first\n";
  std::ofstream(path + ".1") << "older\n";
  const auto kept = keep_earlier_capture(path);
  ASSERT_TRUE(kept);
  EXPECT_EQ(*kept, path + ".2");
  EXPECT_EQ(slurp(*kept), "first\n");
  EXPECT_EQ(slurp(path + ".1"), "older\n");
  EXPECT_FALSE(fs::exists(path));
  std::ofstream(path).flush();  // an empty file is no capture: left to be overwritten
  EXPECT_FALSE(keep_earlier_capture(path));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace lec6::transport
