// Capture files on disk: what the writer wrote reads back; the reader's
// errors name the file.

#include "lec6/transport/capture_file.hpp"

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <csignal>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace lec6::transport {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class CaptureFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("lec6-capture-" + std::to_string(::getpid()) + "-" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  std::string contents(const fs::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
  fs::path dir;
};

modbus::CaptureHeader header() {
  modbus::CaptureHeader h;
  h.source = "tap";
  h.started_utc = "2026-11-24T19:00:00.000000Z";
  h.port = "/tmp/tap";
  h.tool = "lec test";
  return h;
}

TEST_F(CaptureFileTest, WrittenRecordsReadBack) {
  const auto path = (dir / "c.jsonl").string();
  {
    CaptureWriter w(path, header(), std::chrono::milliseconds(5));
    for (int i = 0; i < 1000; ++i)
      w.write({i * 10,
               i * 10 + 5,
               i % 2 ? modbus::CaptureDir::Reply : modbus::CaptureDir::Query,
               {static_cast<uint8_t>(i), 0x03},
               ""});
    EXPECT_EQ(w.records_written(), 1000u);
  }  // the destructor writes out the rest
  const modbus::Capture c = read_capture_file(path);
  EXPECT_EQ(c.header.source, "tap");
  ASSERT_EQ(c.records.size(), 1000u);
  EXPECT_EQ(c.records[999].t_us, 9990);
  EXPECT_EQ(c.records[999].bytes, (modbus::Bytes{0xE7, 0x03}));
}

TEST_F(CaptureFileTest, FlushPutsEverythingOnDisk) {
  const auto path = dir / "c.jsonl";
  CaptureWriter w(path.string(), header(), std::chrono::hours(1));  // never on its own
  w.write({1, 2, modbus::CaptureDir::Noise, {0xFF}, "burst"});
  w.flush();
  const std::string text = contents(path);
  EXPECT_THAT(text, HasSubstr("\"format\":\"lec6-capture\""));
  EXPECT_THAT(text, HasSubstr(R"({"t_us":1,"end_us":2,"dir":"noise","hex":"ff","note":"burst"})"));
  w.close();
  w.close();  // idempotent
  EXPECT_THROW(w.write({3, 4, modbus::CaptureDir::Noise, {0xFF}, ""}), Error);
}

TEST_F(CaptureFileTest, AMissingFileIsAClearError) {
  const auto path = (dir / "nope.jsonl").string();
  try {
    read_capture_file(path);
    FAIL();
  } catch (const InvalidArgument& e) {
    EXPECT_THAT(e.what(), HasSubstr("cannot read " + path));
    EXPECT_THAT(e.what(), HasSubstr("No such file or directory"));
  }
}

TEST_F(CaptureFileTest, ACorruptFileNamesPathLineAndOffset) {
  const auto path = (dir / "cut.jsonl").string();
  {
    CaptureWriter w(path, header());
    w.write({1, 2, modbus::CaptureDir::Query, {0x01, 0x03}, ""});
    w.write({3, 4, modbus::CaptureDir::Reply, {0x01, 0x83}, ""});
  }
  const std::string text = contents(path);
  fs::resize_file(path, text.size() - 10);  // cut in the middle of the last line
  const std::size_t last = text.rfind('\n', text.size() - 2) + 1;
  try {
    read_capture_file(path);
    FAIL();
  } catch (const modbus::CaptureError& e) {
    EXPECT_EQ(e.line(), 3u);
    EXPECT_EQ(e.offset(), last);
    EXPECT_THAT(e.what(), HasSubstr(path + ", line 3 (byte " + std::to_string(last) + ")"));
  }
}

TEST_F(CaptureFileTest, AnUncreatableFileIsAClearError) {
  const auto path = (dir / "no-such-dir" / "c.jsonl").string();
  try {
    CaptureWriter w(path, header());
    FAIL();
  } catch (const InvalidArgument& e) {
    EXPECT_THAT(e.what(), HasSubstr("cannot create " + path));
  }
}

// A FIFO with no reader: refused at once, naming it (open() for writing
// would wait for a reader for ever).
TEST_F(CaptureFileTest, AFifoNobodyReadsIsAClearErrorNotAHang) {
  const auto path = (dir / "unread.pipe").string();
  ASSERT_EQ(::mkfifo(path.c_str(), 0600), 0);
  try {
    CaptureWriter w(path, header());
    FAIL() << "opened a FIFO nobody reads";
  } catch (const InvalidArgument& e) {
    EXPECT_THAT(e.what(),
                HasSubstr("cannot record to " + path + ": it is a FIFO and nothing reads it yet"));
  }
}

// A full disk (/dev/full: every write fails with ENOSPC): the error is told
// once, naming the file; writes never throw and are dropped (memory stays
// bounded); flush() and close() still report it.
TEST_F(CaptureFileTest, AFullDiskIsToldOnceAndWritesGoOn) {
  CaptureWriter w("/dev/full", header(), std::chrono::hours(1));  // flushed by hand
  std::vector<std::string> told;
  w.on_error([&](const std::string& why) { told.push_back(why); });
  w.write({1, 2, modbus::CaptureDir::Query, {0x01, 0x03}, ""});
  EXPECT_THROW(w.flush(), Error);
  ASSERT_EQ(told.size(), 1u);
  EXPECT_EQ(told[0], "cannot write /dev/full: No space left on device");
  for (int i = 0; i < 100; ++i) {
    EXPECT_NO_THROW(w.write({i, i, modbus::CaptureDir::Reply, {0x01, 0x03}, ""}));
  }
  EXPECT_GE(w.records_dropped(), 100u);
  EXPECT_EQ(w.records_written(), 1u);
  EXPECT_THROW(w.flush(), Error);
  EXPECT_THROW(w.close(), Error);
  EXPECT_EQ(told.size(), 1u) << "told once";
}

// Not a regular file: never renamed as an earlier capture (as root,
// /dev/full renamed would be a system's device gone).
TEST_F(CaptureFileTest, OnlyARegularFileIsKeptAsAnEarlierCapture) {
  EXPECT_FALSE(keep_earlier_capture("/dev/full"));
  EXPECT_TRUE(fs::exists("/dev/full"));
  const auto path = dir / "c.jsonl";
  std::ofstream(path) << "x\n";
  EXPECT_EQ(keep_earlier_capture(path.string()), path.string() + ".1");
}

// A disk that fills in the middle of a write (the kernel writes what fits,
// then ENOSPC; RLIMIT_FSIZE gives the same partial write and then EFBIG):
// the records written before must stay readable, so replay and calibrate
// can use the capture up to the failure. Found in review: the last record
// is left half written, and the reader refuses the whole file ("the file
// ends in the middle of this line").
TEST_F(CaptureFileTest, AWriteCutShortLeavesTheEarlierRecordsReadable) {
  const auto path = (dir / "c.jsonl").string();
  struct sigaction ignore {};
  ignore.sa_handler = SIG_IGN;
  struct sigaction before {};
  sigaction(SIGXFSZ, &ignore, &before);
  rlimit saved{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &saved), 0);
  {
    CaptureWriter w(path, header(), std::chrono::hours(1));  // flushed by hand
    for (int i = 0; i < 3; ++i) w.write({i, i, modbus::CaptureDir::Query, {0x01, 0x03}, ""});
    w.flush();
    rlimit small = saved;
    small.rlim_cur = fs::file_size(path) + 100;  // room for about one record more
    ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
    for (int i = 3; i < 20; ++i) w.write({i, i, modbus::CaptureDir::Reply, {0x01, 0x03}, ""});
    EXPECT_THROW(w.flush(), Error);
    ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &saved), 0);
    EXPECT_THROW(w.close(), Error);
  }
  sigaction(SIGXFSZ, &before, nullptr);
  modbus::Capture c;
  EXPECT_NO_THROW(c = read_capture_file(path)) << contents(path);
  EXPECT_GE(c.records.size(), 3u);
}

// A capture whose file stops taking bytes without failing (a pipe to a
// compressor that stalls, an NFS server that hangs): the writer's thread
// waits in write() and every record after waits in memory. Found in review:
// nothing bounds it (lec serve grows for as long as the stall lasts, ~17 KB/s
// at 100 Hz telemetry on one axis) and lec serve's SIGTERM then hangs in
// close() for ever. The records beyond a bound must be dropped and counted.
TEST_F(CaptureFileTest, AStalledFileDropsRecordsInsteadOfGrowing) {
  const auto path = (dir / "stalled.pipe").string();
  ASSERT_EQ(::mkfifo(path.c_str(), 0600), 0);
  const int reader = ::open(path.c_str(), O_RDONLY | O_NONBLOCK);  // never reads
  ASSERT_GE(reader, 0);
  struct sigaction ignore {};
  ignore.sa_handler = SIG_IGN;
  struct sigaction before {};
  sigaction(SIGPIPE, &ignore, &before);
  {
    CaptureWriter w(path, header(), std::chrono::milliseconds(1));
    const modbus::Bytes bytes(64, 0x55);
    for (int i = 0; i < 200000; ++i) w.write({i, i, modbus::CaptureDir::Reply, bytes, ""});
    // ~35 MB of records against a pipe that holds 64 KiB.
    EXPECT_GT(w.records_dropped(), 0u) << "every record is held in memory";
    ::close(reader);  // the writer's write() now fails (EPIPE): close() can end
    EXPECT_THROW(w.close(), Error);
  }
  sigaction(SIGPIPE, &before, nullptr);
}

}  // namespace
}  // namespace lec6::transport
