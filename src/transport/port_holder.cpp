#include "lec6/transport/port_holder.hpp"

#include <unistd.h>

#include <fstream>
#include <iterator>
#include <sstream>

#include <fmt/format.h>

namespace lec6::transport {

namespace {

std::string read_command_line(const std::filesystem::path& pid_dir) {
  std::ifstream in(pid_dir / "cmdline", std::ios::binary);
  std::string raw((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  while (!raw.empty() && raw.back() == '\0') raw.pop_back();
  for (char& c : raw)
    if (c == '\0') c = ' ';
  return raw;
}

// The words of a command line (split at spaces: what /proc gave us).
std::vector<std::string> words(const std::string& line) {
  std::istringstream in(line);
  return {std::istream_iterator<std::string>(in), std::istream_iterator<std::string>()};
}

// `lec serve`'s Modbus TCP address from its command line (its default otherwise).
std::string serve_address(const std::string& line) {
  const auto w = words(line);
  for (std::size_t i = 0; i < w.size(); ++i) {
    if (w[i] == "--modbus-tcp" && i + 1 < w.size()) return w[i + 1];
    if (w[i].rfind("--modbus-tcp=", 0) == 0) return w[i].substr(13);
  }
  return "127.0.0.1:1502";
}

// `lec COMMAND ...` (the first word that is not an option).
bool is_lec(const std::string& line, std::string_view command) {
  const auto w = words(line);
  if (w.empty()) return false;
  const std::string prog = std::filesystem::path(w[0]).filename().string();
  if (prog != "lec") return false;
  for (std::size_t i = 1; i < w.size(); ++i)
    if (w[i] == command) return true;
  return false;
}

}  // namespace

std::vector<PortHolder> port_holders(const std::string& device,
                                     const std::filesystem::path& proc) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path target = fs::canonical(device, ec);
  if (ec) return {};
  std::vector<PortHolder> out;
  for (const auto& entry : fs::directory_iterator(proc, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::error_code fd_ec;
    for (const auto& fd : fs::directory_iterator(entry.path() / "fd", fd_ec)) {
      std::error_code link_ec;
      const fs::path points = fs::read_symlink(fd.path(), link_ec);
      if (link_ec || points != target) continue;
      std::string line = read_command_line(entry.path());
      // The twin (`lec sim --pty`) keeps its pty's far end open: it is the
      // line, not another program using the port.
      if (is_lec(line, "sim")) break;
      out.push_back({std::stoi(name), std::move(line)});
      break;
    }
  }
  return out;
}

std::string port_busy_message(const std::string& device, const std::filesystem::path& proc) {
  const auto holders = port_holders(device, proc);
  std::string who;
  std::string serve_hint;
  for (const auto& h : holders) {
    if (!who.empty()) who += "; ";
    who += fmt::format("pid {}{}", h.pid,
                       h.command_line.empty() ? "" : fmt::format(", {}", h.command_line));
    if (h.pid == ::getpid()) who += " (this program)";
    if (serve_hint.empty() && is_lec(h.command_line, "serve")) {
      const std::string addr = serve_address(h.command_line);
      serve_hint = fmt::format(
          ". lec serve owns this line: go through it with --port tcp://{} (e.g. lec --port "
          "tcp://{} doctor, or status), or stop it (kill {}) to use the port directly",
          addr, addr, h.pid);
    }
  }
  if (who.empty()) {
    return fmt::format(
        "cannot open {}: port busy (another program has it open). If it is lec serve, go through "
        "it with --port tcp://127.0.0.1:1502",
        device);
  }
  std::string msg =
      fmt::format("cannot open {}: port busy (another program has it open: {}){}", device, who,
                  serve_hint);
  if (serve_hint.empty())
    msg += ". To share the line, let lec serve own it and use --port tcp://HOST:1502 elsewhere";
  return msg;
}

}  // namespace lec6::transport
