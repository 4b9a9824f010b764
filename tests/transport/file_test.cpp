// The one atomic file writer (step-table backups, the twin's state file).

#include "lec6/transport/file.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace lec6::transport {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class FileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("lec6-file-" + std::to_string(::getpid()) + "-" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  std::size_t entries() const {
    return static_cast<std::size_t>(
        std::distance(fs::directory_iterator(dir), fs::directory_iterator{}));
  }
  fs::path dir;
};

TEST_F(FileTest, ReplacesTheFileWithANewOneAndLeavesNoTemporary) {
  const fs::path p = dir / "steps.csv";
  std::ofstream(p) << "old";
  struct stat before {};
  ASSERT_EQ(::stat(p.c_str(), &before), 0);
  std::ifstream old_reader(p);  // keeps the old file open
  ASSERT_TRUE(write_file_atomically(p, "new\ncontents\n"));
  struct stat after {};
  ASSERT_EQ(::stat(p.c_str(), &after), 0);
  EXPECT_NE(before.st_ino, after.st_ino);  // a new file renamed over it, not rewritten in place
  std::string old_text;
  std::getline(old_reader, old_text);
  EXPECT_EQ(old_text, "old");
  EXPECT_EQ(*read_file(p), "new\ncontents\n");
  EXPECT_EQ(entries(), 1u);
}

TEST_F(FileTest, NewFilesGetTheUsualPermissions) {
  const fs::path p = dir / "twin.state";
  ASSERT_TRUE(write_file_atomically(p, "x"));
  struct stat st {};
  ASSERT_EQ(::stat(p.c_str(), &st), 0);
  const mode_t mask = ::umask(022);  // this test is single-threaded
  ::umask(mask);
  EXPECT_EQ(st.st_mode & 0777, 0666 & ~mask);
}

TEST_F(FileTest, ErrorsNameThePathAndTheCauseAndChangeNothing) {
  const auto bad = write_file_atomically(dir / "no-such-dir" / "x.csv", "x");
  ASSERT_FALSE(bad);
  EXPECT_THAT(bad.error(), HasSubstr("cannot write "));
  EXPECT_THAT(bad.error(), HasSubstr("no-such-dir/x.csv: No such file or directory"));
  EXPECT_EQ(entries(), 0u);

  const auto missing = read_file(dir / "none.csv");
  ASSERT_FALSE(missing);
  EXPECT_THAT(missing.error(), HasSubstr("cannot read "));
  EXPECT_THAT(missing.error(), HasSubstr("none.csv: No such file or directory"));
}

TEST_F(FileTest, AFileInTheCurrentDirectory) {
  const fs::path cwd = fs::current_path();
  fs::current_path(dir);
  const auto w = write_file_atomically("plain.txt", "here");
  fs::current_path(cwd);
  ASSERT_TRUE(w) << w.error();
  EXPECT_EQ(*read_file(dir / "plain.txt"), "here");
}

// A user's link (steps.csv -> backups/press-7.csv) stays a link: the file it
// names is replaced, in its own directory; a dangling link is replaced itself.
TEST_F(FileTest, ASymlinkStaysAndTheFileItNamesIsReplaced) {
  fs::create_directories(dir / "backups");
  std::ofstream(dir / "backups" / "press-7.csv") << "old";
  fs::create_symlink(fs::path("backups") / "press-7.csv", dir / "steps.csv");
  ASSERT_TRUE(write_file_atomically(dir / "steps.csv", "new"));
  EXPECT_TRUE(fs::is_symlink(dir / "steps.csv"));
  EXPECT_EQ(*read_file(dir / "backups" / "press-7.csv"), "new");
  EXPECT_EQ(entries(), 2u) << "no temporary left beside the link";
  EXPECT_TRUE(fs::equivalent(file_behind(dir / "steps.csv"), dir / "backups" / "press-7.csv"));
  EXPECT_EQ(file_behind(dir / "backups"), dir / "backups");
  // A dangling link: the file it names is created, the link stays.
  fs::create_symlink(fs::path("backups") / "new.csv", dir / "dangling.csv");
  EXPECT_EQ(file_behind(dir / "dangling.csv"), dir / "backups" / "new.csv");
  ASSERT_TRUE(write_file_atomically(dir / "dangling.csv", "made"));
  EXPECT_TRUE(fs::is_symlink(dir / "dangling.csv"));
  EXPECT_EQ(*read_file(dir / "backups" / "new.csv"), "made");
  // A loop of links: the path as given.
  fs::create_symlink(dir / "loop-b", dir / "loop-a");
  fs::create_symlink(dir / "loop-a", dir / "loop-b");
  EXPECT_EQ(file_behind(dir / "loop-a"), dir / "loop-a");
}

// A link to a device (report.csv -> /dev/null) is refused, never replaced.
TEST_F(FileTest, ALinkToADeviceIsRefusedAndTheDeviceStays) {
  fs::create_symlink("/dev/null", dir / "report.csv");
  const auto w = write_file_atomically(dir / "report.csv", "x");
  ASSERT_FALSE(w);
  EXPECT_THAT(w.error(), HasSubstr("/dev/null is not a regular file"));
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
  EXPECT_TRUE(fs::is_symlink(dir / "report.csv"));
}

}  // namespace
}  // namespace lec6::transport
