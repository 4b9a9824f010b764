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

// A user's link to the capture (latest.jsonl -> runs/line.jsonl) stays a
// link: the file it names moves aside beside itself; the new capture, opened
// through the link, lands where the link points.
TEST(KeepEarlierCapture, ASymlinkStaysAndItsFileMovesAsideBesideItself) {
  const fs::path dir =
      fs::temp_directory_path() / fs::path("lec6-rotate-link-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "runs");
  const fs::path target = dir / "runs" / "line.jsonl";
  const fs::path link = dir / "latest.jsonl";
  std::ofstream(target) << "first\n";
  fs::create_symlink(fs::path("runs") / "line.jsonl", link);
  const auto kept = keep_earlier_capture(link.string());
  ASSERT_TRUE(kept);
  EXPECT_EQ(fs::path(*kept), dir / "runs" / "line.jsonl.1");
  EXPECT_EQ(slurp(*kept), "first\n");
  EXPECT_TRUE(fs::is_symlink(link)) << "the user's link was renamed away";
  EXPECT_FALSE(fs::exists(dir / "latest.jsonl.1"));
  std::ofstream(link) << "second\n";  // as the writer opens it: through the link
  EXPECT_EQ(slurp(target), "second\n");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace lec6::transport
