#include "lec6/transport/pty.hpp"

#include <fcntl.h>
#include <stdlib.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <system_error>

#include <fmt/format.h>

#include "lec6/client/link.hpp"

namespace lec6::transport {

namespace {

namespace fs = std::filesystem;
using client::LinkError;
using client::LinkErrorKind;

[[noreturn]] void unavailable(const std::string& what) {
  throw LinkError(LinkErrorKind::PortUnavailable, what);
}

// Raw 8N1, no echo, no line discipline processing.
bool make_raw(int fd) {
  termios tio{};
  if (::tcgetattr(fd, &tio) != 0) return false;
  ::cfmakeraw(&tio);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cc[VMIN] = 1;
  tio.c_cc[VTIME] = 0;
  return ::tcsetattr(fd, TCSANOW, &tio) == 0;
}

}  // namespace

Pty::Pty(fs::path link) {
  const int master = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (master < 0) {
    unavailable(fmt::format("cannot create a pseudo-terminal: {}", errno_text(errno)));
  }
  master_.reset(master);
  if (::grantpt(master) != 0 || ::unlockpt(master) != 0) {
    unavailable(fmt::format("cannot set up a pseudo-terminal: {}", errno_text(errno)));
  }
  char name[128];
  if (int err = ::ptsname_r(master, name, sizeof name); err != 0) {
    unavailable(fmt::format("cannot name a pseudo-terminal: {}", errno_text(err)));
  }
  slave_path_ = name;
  const int slave = ::open(name, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (slave < 0) unavailable(fmt::format("cannot open {}: {}", slave_path_, errno_text(errno)));
  slave_.reset(slave);
  // The slave starts in cooked mode with echo on, which would bounce every
  // byte the twin writes straight back to it.
  if (!make_raw(slave) || !make_raw(master) || !set_nonblocking(master)) {
    unavailable(fmt::format("cannot configure {}: {}", slave_path_, errno_text(errno)));
  }

  if (link.empty()) return;
  std::error_code ec;
  const fs::file_status status = fs::symlink_status(link, ec);
  if (fs::exists(status)) {
    if (!fs::is_symlink(status)) {
      unavailable(fmt::format("{} already exists and is not a symlink: refusing to replace it",
                              link.string()));
    }
    // A symlink at our path is taken for a leftover of an earlier run (its
    // /dev/pts target may even have been reused since): replace it.
    fs::remove(link, ec);
    if (ec) {
      unavailable(
          fmt::format("cannot replace the old symlink {}: {}", link.string(), ec.message()));
    }
  }
  fs::create_symlink(slave_path_, link, ec);
  if (ec) {
    unavailable(fmt::format("cannot create symlink {} -> {}: {}", link.string(), slave_path_,
                            ec.message()));
  }
  link_ = std::move(link);
}

Pty::Pty(Pty&& other) noexcept
    : master_(std::move(other.master_)),
      slave_(std::move(other.slave_)),
      slave_path_(std::move(other.slave_path_)),
      link_(std::move(other.link_)) {
  other.link_.clear();
  other.slave_path_.clear();
}

Pty::~Pty() {
  if (!link_.empty()) {
    // Only remove the link if it is still ours: another twin may have taken
    // the path over since.
    std::error_code ec;
    const fs::path target = fs::read_symlink(link_, ec);
    if (!ec && target == fs::path(slave_path_)) fs::remove(link_, ec);
  }
  master_.reset();  // hangs up clients still on the slave
  slave_.reset();
}

}  // namespace lec6::transport
