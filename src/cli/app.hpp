#pragma once
// What every `lec` command shares: the global options, the session (the
// opened port and client), output helpers and the exit codes.

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <atomic>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "cli/json_output.hpp"
#include "lec6/client/actuator.hpp"
#include "lec6/client/client.hpp"
#include "lec6/error.hpp"
#include "lec6/twin/open_port.hpp"

namespace lec6::cli {

// Exit codes (documented in `lec --help` and the README).
enum ExitCode : int {
  kSuccess = 0,
  kFailure = 1,        // anything else (e.g. a file could not be written)
  kUsage = 2,          // every argument error, including the parser's own
  kTransport = 3,      // port missing or busy, timeout, CRC, framing
  kException = 4,      // the controller answered with an exception (01/02/03)
  kAlarm = 5,          // the controller raised an alarm
  kDeadline = 6,       // a wait ran past its deadline
  kDegraded = 7,       // lec doctor: the line works, but slower or less reliable than it could
  kBroken = 8,         // lec doctor: something on the line does not work
  kInterrupted = 130,  // Ctrl-C (the axis was stopped first)
};

// An argument the user got wrong, found after parsing (exit 2).
class UsageError : public InvalidArgument {
 public:
  using InvalidArgument::InvalidArgument;
};

// A command that failed with a message and an exit code of its own.
class CommandFailed : public Error {
 public:
  CommandFailed(int code, const std::string& what) : Error(what), code_(code) {}
  int code() const noexcept { return code_; }

 private:
  int code_;
};

struct GlobalOptions {
  std::string port;  // --port, else $LEC_PORT
  uint32_t baud = 38400;
  int id = 1;
  Duration reply_margin = std::chrono::milliseconds(50);  // added to the manual's Tx
  int retries = 2;
  bool json = false;
  bool trace = false;
  bool rs485 = false;
  bool rs485_rts_after_send = false;
  Duration rs485_delay_before{};  // whole ms: the kernel's unit
  Duration rs485_delay_after{};
  bool echo = false;  // 2-wire adapter echoes what it sends
  unsigned silent_interval_k = 1;
  Duration delay_td = std::chrono::milliseconds(5);
  bool no_silence_wait = false;  // skip the Ts gap before queries (fast twins, benchmarks only)
  Duration reply_spin{};         // client::RtuOptions::reply_spin (a fast peer only)
  std::string record;            // --record FILE: every frame on the line into a capture file
  std::string soft_limits;       // --soft-limits MIN:MAX (mm); empty: none
  std::string alarm_polarity = "active-high";  // --alarm-polarity (lec/alarm_check.hpp)
  std::string sim_profile =
      "default";  // --sim-profile: the twin of --port sim (default, ideal, FILE)
};

// Before a capture is written at `path` (--record, lec sniff --capture): an
// earlier capture there is kept as path.1, path.2, … and stderr says so
// (transport::keep_earlier_capture; never truncated, as lec serve --record).
void keep_earlier_capture_said(const std::string& path);

// --soft-limits MIN:MAX (mm) → limits; empty → none. UsageError when malformed.
std::optional<client::SoftLimits> parse_soft_limits(const std::string& text);

// A duration the option parser already checked to be whole ms (RS485 delays).
inline uint32_t whole_ms(Duration d) {
  return static_cast<uint32_t>(std::chrono::duration_cast<std::chrono::milliseconds>(d).count());
}

// Set by SIGINT/SIGTERM; waiting operations poll it and stop the axis.
extern std::atomic<bool> g_interrupted;

// The line's timing and RS485 options as the global flags give them (one
// place: every command that opens a port, sessions and cycles alike).
twin::PortOptions line_port_options(const GlobalOptions& options);

class Session {
 public:
  explicit Session(const GlobalOptions& options);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  // Opens the port on first use. With no port at all: UsageError listing the
  // serial ports found. `default_port` is used when neither --port nor
  // LEC_PORT is given (only `lec demo` has one: "sim").
  client::Client& client(std::string_view default_port = {});
  client::Actuator& axis(std::string_view default_port = {});
  // Releases the port (the next client() opens it again).
  void close() noexcept;
  // The command only writes, so `--id 0` (broadcast) can work; call before
  // client(). Every other command refuses ID 0 before opening the port.
  void allow_broadcast() noexcept { allow_broadcast_ = true; }
  const GlobalOptions& options() const noexcept { return options_; }
  bool json() const noexcept { return options_.json; }
  // What the port is, for messages ("/dev/ttyUSB0 @ 38400").
  std::string port_description() const;
  // Wait options that honour Ctrl-C, with an optional progress printer.
  client::WaitOptions wait_options(
      std::function<void(const client::Progress&)> progress = {}) const;
  TimePoint deadline_in(Duration d);

 private:
  struct Impl;
  const GlobalOptions& options_;  // filled in by the parser after construction
  bool allow_broadcast_ = false;
  std::unique_ptr<Impl> impl_;
};

// Each group of commands registers itself on the app. The callback runs the
// command and may throw; main() turns exceptions into messages and exit codes.
void add_status_commands(CLI::App& app, Session& session);  // status, watch, alarms, name
void add_motion_commands(CLI::App& app,
                         Session& session);  // serial, servo, home, move, jog, hold, stop, reset
void add_line_commands(CLI::App& app, Session& session);  // ping, scan, decode, raw, ports, bench
void add_demo_command(CLI::App& app, Session& session);   // demo
void add_step_commands(CLI::App& app, Session& session);  // step list/get/set/backup/restore/diff
void add_sim_command(CLI::App& app, const GlobalOptions& globals);    // sim (the twin program)
void add_serve_command(CLI::App& app, const GlobalOptions& globals);  // serve (the bus owner)
void add_follow_command(CLI::App& app, Session& session);  // follow (streaming setpoints)
void add_sniff_command(CLI::App& app, const GlobalOptions& globals);   // sniff (listen-only)
void add_replay_command(CLI::App& app, const GlobalOptions& globals);  // replay (a capture)
void add_doctor_command(CLI::App& app, Session& session);              // doctor (diagnose the line)
void add_history_commands(CLI::App& app,
                          const GlobalOptions& globals);  // history, health (lec serve)
void add_cycle_commands(CLI::App& app, const GlobalOptions& globals);  // cycle check/run (issue 34)

}  // namespace lec6::cli
