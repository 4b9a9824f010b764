#pragma once
// A pseudo-terminal pair for the digital twin: the twin serves the master
// side, masters (lec, pymodbus, mbpoll, ...) open the slave path as if it were
// a serial port.
//
// Thread safety: a Pty is used by one thread at a time; its descriptor may be polled from the
// thread that serves it.

#include <filesystem>
#include <string>

#include "lec6/transport/fd.hpp"

namespace lec6::transport {

class Pty {
 public:
  // Creates the pair (posix_openpt/grantpt/unlockpt), puts both sides in raw
  // mode and the master in non-blocking mode. With a non-empty `link`, also
  // creates a symlink there pointing at the slave path: an existing symlink
  // (left over from an earlier run) is replaced, anything else is refused.
  // Throws client::LinkError (PortUnavailable) with the path in the message.
  explicit Pty(std::filesystem::path link = {});
  // Removes the symlink (if it still points at our slave), then closes the
  // master, which hangs up any client still holding the slave.
  ~Pty();
  Pty(Pty&& other) noexcept;
  Pty& operator=(Pty&&) = delete;
  Pty(const Pty&) = delete;
  Pty& operator=(const Pty&) = delete;

  // Non-blocking, raw. Poll it for POLLIN; write replies to it.
  int master_fd() const { return master_.get(); }
  // e.g. "/dev/pts/3".
  const std::string& slave_path() const { return slave_path_; }
  // The symlink, or empty if none was asked for.
  const std::filesystem::path& link_path() const { return link_; }
  // What clients should open: the symlink if any, else the slave path.
  std::string client_path() const { return link_.empty() ? slave_path_ : link_.string(); }

 private:
  UniqueFd master_;
  // A slave descriptor we hold open ourselves. On Linux, once no process has
  // the slave open the master reads EIO and polls POLLHUP continuously, so an
  // event loop on the master would spin (or have to reopen the pair) between
  // clients. Holding one slave descriptor keeps the master quiet and readable
  // across client connects and disconnects, and keeps the slave's raw termios
  // in place for clients that do not configure the port themselves.
  UniqueFd slave_;
  std::string slave_path_;
  std::filesystem::path link_;
};

}  // namespace lec6::transport
