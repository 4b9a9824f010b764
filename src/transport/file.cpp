#include "lec6/transport/file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include <fmt/format.h>

namespace lec6::transport {
namespace {

std::string os_error(std::string_view what, const std::filesystem::path& path, int err) {
  return fmt::format("cannot {} {}: {}", what, path.string(), std::strerror(err));
}

// A temporary file next to `path`, with its name filled in (mkstemp).
int make_temporary(const std::filesystem::path& path, std::string& name) {
  const std::filesystem::path dir =
      path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  // Appended piecewise: `"." + a + b` trips GCC 12's -Wrestrict false positive at -O3.
  std::string file = ".";
  file += path.filename().string();
  file += ".tmp-XXXXXX";
  name = (dir / file).string();
  return ::mkstemp(name.data());
}

// The process's umask, without changing it even for an instant (umask(2)
// only reads it by setting it, which would race with other threads).
mode_t current_umask() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("Umask:", 0) == 0)
      return static_cast<mode_t>(std::strtoul(line.c_str() + 6, nullptr, 8));
  }
  return 022;
}

bool write_all(int fd, std::string_view contents) {
  std::size_t done = 0;
  while (done < contents.size()) {
    const ssize_t n = ::write(fd, contents.data() + done, contents.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n == 0) errno = EIO;
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace

Expected<std::string, std::string> read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return unexpected(os_error("read", path, errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return unexpected(fmt::format("cannot read {}: read error", path.string()));
  return text.str();
}

std::filesystem::path file_behind(const std::filesystem::path& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path p = path;
  // Link by link, so that a dangling link names the file it will create
  // (as open(2) does), and a relative target counts from its link's directory.
  for (int hops = 0; hops < 40 && fs::is_symlink(p, ec); ++hops) {
    const fs::path target = fs::read_symlink(p, ec);
    if (ec) return path;
    p = target.is_absolute() ? target : p.parent_path() / target;
  }
  return fs::is_symlink(p, ec) ? path : p;  // a loop: the path as given (its write fails)
}

Expected<void, std::string> write_file_atomically(const std::filesystem::path& given,
                                                  std::string_view contents) {
  const std::filesystem::path path = file_behind(given);
  std::error_code ec;
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec)) {
    return unexpected(
        fmt::format("cannot write {}: {} is not a regular file (a directory, a "
                    "device or a FIFO): give a file name",
                    given.string(), path.string()));
  }
  std::string tmp;
  const int fd = make_temporary(path, tmp);
  if (fd < 0) return unexpected(os_error("write", path, errno));
  auto abandon = [&] {
    const int err = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    return unexpected(os_error("write", path, err));
  };
  if (!write_all(fd, contents)) return abandon();
  // mkstemp makes the file 0600; the data is an ordinary file of the user's.
  if (::fchmod(fd, 0666 & ~current_umask()) != 0 || ::fsync(fd) != 0) return abandon();
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    return unexpected(os_error("write", path, err));
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    return unexpected(os_error("write", path, err));
  }
  // The rename is durable once the directory is on disk too.
  const std::filesystem::path dir =
      path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    (void)::fsync(dfd);
    ::close(dfd);
  }
  return {};
}

}  // namespace lec6::transport
