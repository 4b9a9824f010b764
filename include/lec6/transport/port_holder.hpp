#pragma once
// Who holds a serial port open, from /proc (Linux): for the "port busy"
// message, which names the holder and, when it is `lec serve`, how to go
// through it instead.
//
// Thread safety: pure functions over the file system.

#include <filesystem>
#include <string>
#include <vector>

namespace lec6::transport {

struct PortHolder {
  int pid = 0;
  std::string command_line;  // arguments joined by spaces; empty when /proc does not tell
};

// The processes with `device` (symlinks resolved) open, by pid; those whose
// descriptors we may not read are missing.
std::vector<PortHolder> port_holders(const std::string& device,
                                     const std::filesystem::path& proc = "/proc");

// "cannot open DEV: port busy (another program has it open: pid N, CMD)" and,
// for `lec serve`, how to reach the controllers through it or stop it.
std::string port_busy_message(const std::string& device,
                              const std::filesystem::path& proc = "/proc");

}  // namespace lec6::transport
