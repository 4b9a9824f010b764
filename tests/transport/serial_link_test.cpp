// SerialLink and Pty against real pseudo-terminals: no mocks, no sleeps. Every
// wait is a poll() on a real descriptor with a deadline.
// Over 450 lines: every serial-port behaviour (open, exclusive mode, RS485,
// echo, low latency, faults) needs its own real pty case.

#include <fcntl.h>
#include <poll.h>
#include <stdlib.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "lec6/error.hpp"
#include "lec6/transport/fd.hpp"
#include "lec6/transport/port_spec.hpp"
#include "lec6/transport/pty.hpp"
#include "lec6/transport/serial_link.hpp"
#include "read_link.hpp"

namespace lec6::transport {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using client::LinkError;
using client::LinkErrorKind;
using ::testing::AllOf;
using ::testing::HasSubstr;

const SteadyClock kSerialClock;
using Bytes = std::vector<uint8_t>;

// Read 2 registers from D9000 of controller 1 (a frame from the manual).
const Bytes kQuery = {0x01, 0x03, 0x90, 0x00, 0x00, 0x02, 0xE9, 0x0B};
const Bytes kReply = {0x01, 0x03, 0x04, 0x00, 0x00, 0x27, 0x10, 0xE2, 0x1F};

TimePoint from_now(Duration d) {
  return kSerialClock.now() + d;
}

void write_fd(int fd, std::span<const uint8_t> data) {
  const TimePoint deadline = from_now(2s);
  std::size_t done = 0;
  while (done < data.size()) {
    const ssize_t n = ::write(fd, data.data() + done, data.size() - done);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
      continue;
    }
    ASSERT_TRUE(errno == EAGAIN || errno == EINTR) << errno_text(errno);
    ASSERT_NE(poll_until(fd, POLLOUT, deadline, kSerialClock), 0) << "write timed out";
  }
}

// Up to `count` bytes from `fd`, waiting at most `timeout` for all of them.
Bytes read_fd(int fd, std::size_t count, Duration timeout = 2s) {
  const TimePoint deadline = from_now(timeout);
  Bytes out;
  while (out.size() < count) {
    if (poll_until(fd, POLLIN, deadline, kSerialClock) == 0) break;
    uint8_t buffer[256];
    const ssize_t n = ::read(fd, buffer, std::min(sizeof buffer, count - out.size()));
    if (n > 0) out.insert(out.end(), buffer, buffer + n);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) break;
  }
  return out;
}

using testing::read_link;

// Runs `f`, which must throw LinkError, and returns it.
LinkError link_error(const std::function<void()>& f) {
  try {
    f();
  } catch (const LinkError& e) {
    return e;
  }
  ADD_FAILURE() << "no LinkError thrown";
  return LinkError(LinkErrorKind::Io, "none");
}

class TempDir {
 public:
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "lec6-transport-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

void write_file(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

std::string read_file(const fs::path& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// --- round trips at every supported speed -----------------------------------

class SerialOverPty : public ::testing::TestWithParam<uint32_t> {};

TEST_P(SerialOverPty, BytesFlowBothWays) {
  Pty pty;
  SerialLink link(pty.slave_path(), SerialOptions{.baud = GetParam()});
  EXPECT_EQ(link.baud(), GetParam());
  EXPECT_EQ(link.describe(), pty.slave_path() + " @ " + std::to_string(GetParam()));

  link.write(kQuery);
  EXPECT_EQ(read_fd(pty.master_fd(), kQuery.size()), kQuery);

  write_fd(pty.master_fd(), kReply);
  EXPECT_EQ(read_link(link, kReply.size()), kReply);
}

INSTANTIATE_TEST_SUITE_P(AllSpeeds, SerialOverPty,
                         ::testing::Values(9600u, 19200u, 38400u, 57600u, 115200u, 230400u));

TEST(SerialLink, ReadSomeReturnsZeroOnlyOnceTheDeadlineHasPassed) {
  Pty pty;
  SerialLink link(pty.slave_path());
  uint8_t buffer[16];
  const TimePoint deadline = from_now(30ms);
  EXPECT_EQ(link.read_some(buffer, deadline), 0u);
  EXPECT_GE(link.clock().now(), deadline);
}

TEST(SerialLink, ReadSomeWithAPastDeadlineStillReturnsWhatIsThere) {
  Pty pty;
  SerialLink link(pty.slave_path());
  write_fd(pty.master_fd(), kReply);
  ASSERT_NE(poll_until(link.fd(), POLLIN, from_now(2s), kSerialClock), 0);
  uint8_t buffer[64];
  const std::size_t n = link.read_some(buffer, kSerialClock.now() - 1ms);
  ASSERT_GT(n, 0u);
  EXPECT_TRUE(std::equal(buffer, buffer + n, kReply.begin()));
}

TEST(SerialLink, ReadSomeReturnsAsSoonAsBytesArriveWithoutWaitingForMore) {
  Pty pty;
  SerialLink link(pty.slave_path());
  write_fd(pty.master_fd(), Bytes{0x01, 0x03});
  uint8_t buffer[64];
  const TimePoint deadline = from_now(10s);
  EXPECT_EQ(link.read_some(buffer, deadline), 2u);
  EXPECT_LT(kSerialClock.now(), deadline - 9s);
}

TEST(SerialLink, ReadSomeExactReturnsZeroOnlyOnceTheDeadlineHasPassed) {
  Pty pty;
  SerialLink link(pty.slave_path());  // sleeps, then polls the last 200 µs
  uint8_t buffer[16];
  const TimePoint deadline = from_now(30ms);
  EXPECT_EQ(link.read_some_exact(buffer, deadline), 0u);
  EXPECT_GE(link.clock().now(), deadline);
}

TEST(SerialLink, ReadSomeExactReturnsBytesThatArriveWhilePolling) {
  Pty pty;
  SerialOptions o;
  o.spin_before_deadline = 10s;  // the whole wait is the polling stretch
  SerialLink link(pty.slave_path(), o);
  write_fd(pty.master_fd(), Bytes{0x01, 0x03});
  uint8_t buffer[64];
  const TimePoint deadline = from_now(10s);
  EXPECT_EQ(link.read_some_exact(buffer, deadline), 2u);
  EXPECT_LT(kSerialClock.now(), deadline - 9s);
}

TEST(SerialLink, ReadSomeExactWithoutSpinIsReadSome) {
  Pty pty;
  SerialOptions o;
  o.spin_before_deadline = Duration::zero();
  SerialLink link(pty.slave_path(), o);
  uint8_t buffer[16];
  const TimePoint deadline = from_now(20ms);
  EXPECT_EQ(link.read_some_exact(buffer, deadline), 0u);
  EXPECT_GE(link.clock().now(), deadline);
  write_fd(pty.master_fd(), Bytes{0x05});
  EXPECT_EQ(link.read_some_exact(buffer, from_now(10s)), 1u);
}

TEST(SerialLink, DiscardInputDropsStaleBytes) {
  Pty pty;
  SerialLink link(pty.slave_path());
  write_fd(pty.master_fd(), Bytes{0xAA, 0xBB, 0xCC});
  ASSERT_NE(poll_until(link.fd(), POLLIN, from_now(2s), kSerialClock), 0);  // they have arrived
  link.discard_input();
  uint8_t buffer[16];
  EXPECT_EQ(link.read_some(buffer, from_now(20ms)), 0u);

  write_fd(pty.master_fd(), kReply);
  EXPECT_EQ(read_link(link, kReply.size()), kReply);
}

// --- local echo (2-wire adapters) -------------------------------------------

// Plays a 2-wire adapter on the master side: reads what the link sends and
// writes `transform(sent)` back.
std::jthread echo_peer(int master, std::size_t count, std::function<Bytes(Bytes)> transform) {
  return std::jthread([=] {
    Bytes sent = read_fd(master, count, 5s);
    Bytes echo = transform(sent);
    write_fd(master, echo);
  });
}

TEST(SerialLink, MatchingEchoIsSwallowed) {
  Pty pty;
  SerialLink link(pty.slave_path(), SerialOptions{.discard_echo = true});
  {
    auto peer = echo_peer(pty.master_fd(), kQuery.size(), [](Bytes b) { return b; });
    link.write(kQuery);
  }
  write_fd(pty.master_fd(), kReply);
  EXPECT_EQ(read_link(link, kReply.size()), kReply);  // the reply, and not the echo
}

TEST(SerialLink, EchoThatDiffersIsABusCollision) {
  Pty pty;
  SerialLink link(pty.slave_path(), SerialOptions{.discard_echo = true});
  auto peer = echo_peer(pty.master_fd(), kQuery.size(), [](Bytes b) {
    b[1] = 0x83;
    return b;
  });
  const LinkError e = link_error([&] { link.write(kQuery); });
  EXPECT_EQ(e.kind(), LinkErrorKind::EchoMismatch);
  EXPECT_THAT(e.what(), AllOf(HasSubstr("bus collision"), HasSubstr("sent 01 03 90 00 00 02 E9 0B"),
                              HasSubstr("echoed 01 83 90 00 00 02 E9 0B")));
}

TEST(SerialLink, MissingEchoIsReportedAfterTheEchoTimeout) {
  Pty pty;
  SerialLink link(pty.slave_path(), SerialOptions{.discard_echo = true,
                                                  .echo_timeout = std::chrono::milliseconds(20)});
  const LinkError e = link_error([&] { link.write(kQuery); });
  EXPECT_EQ(e.kind(), LinkErrorKind::EchoMismatch);
  EXPECT_THAT(e.what(), AllOf(HasSubstr("echoed (nothing)"), HasSubstr("only 0 of 8")));
}

// --- the device going away ---------------------------------------------------

TEST(SerialLink, ClosingThePtyMasterMakesReadThrowPortLostPromptly) {
  std::optional<Pty> pty(std::in_place);
  const std::string path = pty->slave_path();
  SerialLink link(path);
  pty.reset();
  uint8_t buffer[16];
  const TimePoint deadline = from_now(10s);
  const LinkError e = link_error([&] { link.read_some(buffer, deadline); });
  EXPECT_EQ(e.kind(), LinkErrorKind::PortLost);
  EXPECT_THAT(e.what(), HasSubstr("the serial port " + path + " went away"));
  EXPECT_LT(kSerialClock.now(), deadline - 9s);
}

TEST(SerialLink, ClosingThePtyMasterMakesWriteThrowPortLost) {
  std::optional<Pty> pty(std::in_place);
  const std::string path = pty->slave_path();
  SerialLink link(path);
  pty.reset();
  const TimePoint start = kSerialClock.now();
  const LinkError e = link_error([&] { link.write(kQuery); });
  EXPECT_EQ(e.kind(), LinkErrorKind::PortLost);
  EXPECT_THAT(e.what(), HasSubstr(path));
  EXPECT_LT(kSerialClock.now() - start, 1s);
}

TEST(SerialLink, ClosingThePtyMasterMakesDiscardThrowPortLost) {
  std::optional<Pty> pty(std::in_place);
  SerialLink link(pty->slave_path());
  pty.reset();
  EXPECT_EQ(link_error([&] { link.discard_input(); }).kind(), LinkErrorKind::PortLost);
}

// --- opening -------------------------------------------------------------------

TEST(SerialLink, UnsupportedBaudIsRefusedBeforeOpening) {
  try {
    SerialLink link("/dev/does-not-matter", SerialOptions{.baud = 12345});
    FAIL() << "opened at 12345 baud";
  } catch (const lec6::InvalidArgument& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("12345"), HasSubstr("38400"), HasSubstr("230400")));
  }
  EXPECT_FALSE(is_supported_baud(12345));
  EXPECT_FALSE(is_supported_baud(4800));
  EXPECT_TRUE(is_supported_baud(38400));
}

TEST(SerialLink, MissingDeviceIsPortUnavailableNamingThePath) {
  const LinkError e = link_error([] { SerialLink link("/dev/ttyUSB-lec6-test-missing"); });
  EXPECT_EQ(e.kind(), LinkErrorKind::PortUnavailable);
  EXPECT_STREQ(e.what(), "cannot open /dev/ttyUSB-lec6-test-missing: No such file or directory");
}

TEST(SerialLink, ARegularFileIsNotASerialPort) {
  TempDir dir;
  write_file(dir.path() / "plain", "x");
  const LinkError e = link_error([&] { SerialLink link((dir.path() / "plain").string()); });
  EXPECT_EQ(e.kind(), LinkErrorKind::PortUnavailable);
  EXPECT_THAT(e.what(), HasSubstr("not a serial device"));
}

TEST(SerialLink, ASecondOpenerFindsThePortBusy) {
  Pty pty;
  SerialLink first(pty.slave_path());
  const LinkError e = link_error([&] { SerialLink second(pty.slave_path()); });
  EXPECT_EQ(e.kind(), LinkErrorKind::PortUnavailable);
  // The holder is named (here: this test itself).
  EXPECT_THAT(e.what(), HasSubstr("cannot open " + pty.slave_path() +
                                  ": port busy (another program has it open: pid " +
                                  std::to_string(::getpid())));
}

TEST(SerialLink, ThePortCanBeReopenedAfterClose) {
  Pty pty;
  { SerialLink first(pty.slave_path()); }
  SerialLink second(pty.slave_path());
  second.write(kQuery);
  EXPECT_EQ(read_fd(pty.master_fd(), kQuery.size()), kQuery);
}

// TIOCEXCL is a flag on the tty, which the Pty keeps open: it must be cleared
// when the link closes (or fails to open), or the next client gets EBUSY.
int exclusive_flag(const std::string& path) {
  UniqueFd fd(::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK));  // root ignores TIOCEXCL
  int flag = -1;
  if (!fd || ::ioctl(fd.get(), TIOCGEXCL, &flag) != 0) return -1;
  return flag;
}

TEST(SerialLink, ExclusiveModeIsClearedOnCloseAndOnFailedOpen) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to open an exclusive tty to inspect it";
  Pty pty;
  {
    SerialLink link(pty.slave_path());
    EXPECT_EQ(exclusive_flag(pty.slave_path()), 1);
  }
  EXPECT_EQ(exclusive_flag(pty.slave_path()), 0);
  EXPECT_THROW(SerialLink(pty.slave_path(), SerialOptions{.rs485 = Rs485Options{.enabled = true}}),
               LinkError);
  EXPECT_EQ(exclusive_flag(pty.slave_path()), 0);
}

TEST(SerialLink, KernelRs485RefusedByThePtyDriverNamesPortAndIoctl) {
  Pty pty;
  const LinkError e = link_error([&] {
    SerialLink link(pty.slave_path(), SerialOptions{.rs485 = Rs485Options{.enabled = true}});
  });
  EXPECT_EQ(e.kind(), LinkErrorKind::PortUnavailable);
  EXPECT_THAT(e.what(), AllOf(HasSubstr(pty.slave_path()), HasSubstr("TIOCSRS485")));
}

TEST(SerialLink, LowLatencyIsQuietlySkippedWhereTheDriverLacksIt) {
  Pty pty;
  SerialLink link(pty.slave_path(), SerialOptions{.low_latency = true});
  EXPECT_TRUE(link.warnings().empty());
}

// --- USB latency_timer ---------------------------------------------------------

TEST(LatencyTimer, AboveOneMillisecondWarnsNamingTheFileAndTheFix) {
  TempDir sys;
  const fs::path file = sys.path() / "bus/usb-serial/devices/ttyUSB0/latency_timer";
  write_file(file, "16\n");
  const auto warning = check_latency_timer("/dev/ttyUSB0", sys.path());
  ASSERT_TRUE(warning.has_value());
  EXPECT_THAT(*warning, AllOf(HasSubstr(file.string() + " is 16 ms"),
                              HasSubstr("echo 1 > " + file.string())));
}

TEST(LatencyTimer, OneMillisecondOrNoFileGivesNoWarning) {
  TempDir sys;
  write_file(sys.path() / "bus/usb-serial/devices/ttyUSB0/latency_timer", "1\n");
  EXPECT_FALSE(check_latency_timer("/dev/ttyUSB0", sys.path()).has_value());
  EXPECT_FALSE(check_latency_timer("/dev/ttyUSB1", sys.path()).has_value());
  EXPECT_FALSE(check_latency_timer("/dev/ttyS0", sys.path()).has_value());
}

TEST(LatencyTimer, TheTtyNameIsResolvedThroughSymlinks) {
  TempDir dir;
  write_file(dir.path() / "sys/bus/usb-serial/devices/ttyUSB3/latency_timer", "16");
  write_file(dir.path() / "dev/ttyUSB3", "");
  fs::create_directories(dir.path() / "dev/serial/by-id");
  const fs::path by_id = dir.path() / "dev/serial/by-id/usb-FTDI_FT232R_A1B2C3-if00-port0";
  fs::create_symlink("../../ttyUSB3", by_id);
  const auto warning = check_latency_timer(by_id.string(), dir.path() / "sys");
  ASSERT_TRUE(warning.has_value());
  EXPECT_THAT(*warning, HasSubstr("ttyUSB3/latency_timer"));
}

TEST(LatencyTimer, SerialLinkReportsItAsAWarning) {
  Pty pty;
  TempDir sys;
  const std::string tty = fs::path(pty.slave_path()).filename().string();  // "3" for /dev/pts/3
  write_file(sys.path() / "bus/usb-serial/devices" / tty / "latency_timer", "16\n");
  SerialLink link(pty.slave_path(), SerialOptions{.sysfs_root = sys.path()});
  ASSERT_EQ(link.warnings().size(), 1u);
  EXPECT_THAT(link.warnings()[0], HasSubstr("latency_timer is 16 ms"));
}

// --- Pty -------------------------------------------------------------------------

TEST(Pty, MasterIsNonBlockingAndSlaveIsRaw) {
  Pty pty;
  EXPECT_TRUE(::fcntl(pty.master_fd(), F_GETFL) & O_NONBLOCK);
  EXPECT_THAT(pty.slave_path(), ::testing::StartsWith("/dev/pts/"));
  EXPECT_EQ(pty.client_path(), pty.slave_path());
  // A cooked slave would echo this back to the master.
  write_fd(pty.master_fd(), Bytes{'a', 'b', '\n'});
  EXPECT_EQ(poll_until(pty.master_fd(), POLLIN, from_now(50ms), kSerialClock), 0);
}

TEST(Pty, MasterStaysQuietBetweenClients) {
  Pty pty;
  {
    SerialLink client(pty.slave_path());
    client.write(kQuery);
  }
  // The client is gone: no EIO, no HUP on the master, and what it sent is there.
  EXPECT_EQ(read_fd(pty.master_fd(), kQuery.size()), kQuery);
  EXPECT_EQ(poll_until(pty.master_fd(), POLLIN, from_now(20ms), kSerialClock), 0);
  uint8_t byte;
  EXPECT_EQ(::read(pty.master_fd(), &byte, 1), -1);
  EXPECT_EQ(errno, EAGAIN);

  SerialLink next(pty.slave_path());
  write_fd(pty.master_fd(), kReply);
  EXPECT_EQ(read_link(next, kReply.size()), kReply);
}

TEST(Pty, SymlinkAppearsAndIsRemovedOnDestruction) {
  TempDir dir;
  const fs::path link = dir.path() / "lec-sim";
  {
    Pty pty(link);
    EXPECT_EQ(pty.link_path(), link);
    EXPECT_EQ(pty.client_path(), link.string());
    ASSERT_TRUE(fs::is_symlink(link));
    EXPECT_EQ(fs::read_symlink(link), fs::path(pty.slave_path()));
    SerialLink client(link.string());
    client.write(kQuery);
    EXPECT_EQ(read_fd(pty.master_fd(), kQuery.size()), kQuery);
  }
  EXPECT_FALSE(fs::exists(fs::symlink_status(link)));
}

TEST(Pty, StaleSymlinkIsReplaced) {
  TempDir dir;
  const fs::path link = dir.path() / "lec-sim";
  fs::create_symlink("/dev/pts/lec6-stale-999", link);
  Pty pty(link);
  EXPECT_EQ(fs::read_symlink(link), fs::path(pty.slave_path()));
}

TEST(Pty, RegularFileIsNotOverwritten) {
  TempDir dir;
  const fs::path file = dir.path() / "precious";
  write_file(file, "keep me");
  const LinkError e = link_error([&] { Pty pty(file); });
  EXPECT_EQ(e.kind(), LinkErrorKind::PortUnavailable);
  EXPECT_THAT(e.what(), AllOf(HasSubstr(file.string()), HasSubstr("not a symlink")));
  EXPECT_EQ(read_file(file), "keep me");
}

TEST(Pty, DestructorLeavesALinkThatAnotherPtyTookOver) {
  TempDir dir;
  const fs::path link = dir.path() / "lec-sim";
  std::optional<Pty> first(std::in_place, link);
  Pty second(link);
  first.reset();
  ASSERT_TRUE(fs::is_symlink(link));
  EXPECT_EQ(fs::read_symlink(link), fs::path(second.slave_path()));
}

TEST(Pty, MovedFromPtyDoesNotRemoveTheLink) {
  TempDir dir;
  const fs::path link = dir.path() / "lec-sim";
  std::optional<Pty> first(std::in_place, link);
  Pty moved(std::move(*first));
  first.reset();
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_GE(moved.master_fd(), 0);
}

// --- listing ports -----------------------------------------------------------------

TEST(ListSerialPorts, FindsUsbAcmAndRealUartsWithByIdNames) {
  TempDir root;
  const fs::path dev = root.path() / "dev";
  const fs::path sys = root.path() / "sys";
  for (const char* name : {"ttyUSB0", "ttyUSB1", "ttyACM0", "ttyS0", "ttyS1", "ttyS10", "ttyS2",
                           "ttyXRUSB0", "tty1", "ttyUSBx"}) {
    write_file(dev / name, "");
  }
  fs::create_directories(dev / "serial/by-id");
  fs::create_symlink("../../ttyUSB1",
                     dev / "serial/by-id/usb-FTDI_FT232R_USB_UART_A10K-if00-port0");
  fs::create_symlink("../../ttyXRUSB0", dev / "serial/by-id/usb-Exar_XR21V1410-if00");
  fs::create_symlink("../../ttyUSB9", dev / "serial/by-id/usb-gone-if00");  // dangling
  // ttyS0 and ttyS10 are real, ttyS1 has no device, ttyS2 is an 8250 placeholder.
  fs::create_directories(sys / "class/tty/ttyS0/device");
  write_file(sys / "class/tty/ttyS0/type", "4\n");
  fs::create_directories(sys / "class/tty/ttyS1");
  fs::create_directories(sys / "class/tty/ttyS2/device");
  write_file(sys / "class/tty/ttyS2/type", "0\n");
  fs::create_directories(sys / "class/tty/ttyS10/device");

  const auto ports = list_serial_ports(dev, sys);
  const std::string d = dev.string();
  const std::string real_dev = fs::canonical(dev).string();
  const std::vector<SerialPortInfo> expected = {
      {d + "/ttyACM0", "USB CDC-ACM device"},
      {d + "/ttyS0", "built-in UART"},
      {d + "/ttyS10", "built-in UART"},
      {d + "/ttyUSB0", "USB serial adapter"},
      {d + "/ttyUSB1", "usb-FTDI_FT232R_USB_UART_A10K-if00-port0"},
      {real_dev + "/ttyXRUSB0", "usb-Exar_XR21V1410-if00"},
  };
  EXPECT_EQ(ports, expected);
}

TEST(ListSerialPorts, MissingDirectoriesGiveAnEmptyList) {
  TempDir root;
  EXPECT_TRUE(list_serial_ports(root.path() / "dev", root.path() / "sys").empty());
}

}  // namespace
}  // namespace lec6::transport
