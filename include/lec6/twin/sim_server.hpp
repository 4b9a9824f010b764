#pragma once
// The twin's event loop (`lec sim`): a sim::Bus served on a pseudo-terminal
// and/or a TCP listener, on the wall clock.
//
// One thread, one ppoll(): on the pty master, the listener, every client
// socket and a stop eventfd, with a timeout to the next instant anything is
// due (a frame's silent interval, a reply, a debounced state save), at
// nanosecond precision and with the thread's timer slack set to 1 ns; the
// last stretch before a reply's write instant is spun (spin_before_write),
// because timer wake-ups come late by tens of microseconds. With nothing
// pending it blocks indefinitely: an idle twin uses no CPU.
//
// Timing of a transaction in real timing (digest §1). A pty (or a socket)
// delivers the master's bytes at once and the master's write (tcdrain)
// returns at once, so the master's clock starts at about the moment we read
// the query. We model the RS485 line the bytes would have crossed:
//
//   - a chunk read at time t is put on a virtual line that carries one
//     character per char time (10 bits at the configured baud), starting at
//     max(t, end of the previous byte on it); each byte is given to the bus
//     with the time its last bit would have arrived. So the query's last byte
//     "arrives" at t + wire(query), and the bus delimits frames by Ts on
//     those times, as a controller on a real line would;
//   - the bus schedules the reply's start at end of query + Ts + 4 ms + Td and
//     its end one reply wire time later (sim::Reply::end);
//   - we write the whole reply to the master at Reply::end, because the pty
//     hands it to the client at once: the client then holds the complete
//     reply exactly when its last byte would have arrived on a real line.
//
//   So a master that starts writing at t0 ≈ t has the complete reply at
//     t + wire(query) + Ts + 4 ms + Td + wire(reply)   = t0 + the limit
//   (plus our wake-up latency, tens of microseconds). The same rule serves
//   TCP clients (RTU frames over TCP: the line is behind the socket).
//
// In fast timing there is no virtual line and no artificial delay: a chunk
// is given to the bus with the time it was read, and each reply is written
// at Reply::start, the moment the bus has it.
//
// All sources (the pty and every TCP client) feed the one bus, as masters on
// one RS485 line would; each reply goes back to the source whose bytes ended
// the frame it answers (replies to a closed connection are dropped).
//
// Thread safety: run() on one thread; stop() from any thread or a signal handler; stats() is a racy
// snapshot until run() returns. The Bus belongs to run()'s thread while it runs.

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "lec6/clock.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/sim/state_file.hpp"
#include "lec6/transport/fd.hpp"
#include "lec6/transport/pty.hpp"
#include "lec6/transport/tcp_server.hpp"

namespace lec6::twin {

struct SimServerOptions {
  // Serve a pseudo-terminal; with a non-empty `pty_link`, also a symlink to
  // its slave there (created when the server is constructed, i.e. once the
  // bus is ready; removed when the server is destroyed).
  bool pty = false;
  std::filesystem::path pty_link;
  // Serve RTU frames over TCP on this address and port (0: a free port).
  std::optional<std::pair<std::string, uint16_t>> tcp;
  // Where to keep the bus's EEPROM (sim/state_file.hpp); empty: nowhere.
  // Saved (atomically, on a background thread so the loop never waits on the
  // disk) at most every `save_interval` while it changes, and when run() ends.
  std::filesystem::path state_file;
  Duration save_interval = std::chrono::milliseconds(200);
  // Controllers in the loaded state file that are not on this bus (a twin
  // started with fewer --ids): written back unchanged, so nothing is lost.
  sim::EepromSet state_carry;
  // One line per frame (received query, sent reply), with a timestamp;
  // null: no trace. Called from the loop's thread.
  std::function<void(const std::string&)> trace;
  // Problems that do not stop the twin (a state file that cannot be written,
  // a reply that could not be delivered). Called from any thread.
  std::function<void(const std::string&)> warn;
  // Timers wake tens of microseconds late on most machines (more in VMs),
  // even with 1 ns slack. To write a reply at its instant, the loop wakes
  // this much before it and spins the rest (only then: idle, it blocks).
  // Zero: sleep only.
  Duration spin_before_write = std::chrono::microseconds(200);
  // The pty hands replies (and noise) to the master the way a USB adapter
  // does: in lumps at latency-timer ticks (sim/usb_latency.hpp). Zero: each
  // reply whole, at its instant.
  Duration usb_latency{};
  // The tap: a listen-only pseudo-terminal (symlink at `tap_link`) carrying
  // every byte on the simulated line, from every master and controller, and
  // the line's noise, each at the instant its last bit is on the line (in
  // lumps with a non-zero `tap_latency`). What is written to it is discarded.
  std::filesystem::path tap_link;
  Duration tap_latency{};
  // Line faults the pty plays (lec doctor's test bench; TCP clients are not affected):
  // a 2-wire adapter that echoes: every byte the master writes comes back to it at once;
  bool echo_adapter = false;
  // the controllers answer only at the line's baud: a master whose port is set to
  // another rate (its termios, read on the pty's master side) is heard as
  // garbage, as a UART at the wrong speed would hear it, and hears garbage;
  bool strict_baud = false;
  // a second master on the line, reading D9000 of `other_master_id` every
  // `other_master_period` (0: none): its queries and the replies reach every master.
  Duration other_master_period{};
  uint8_t other_master_id = 1;
};

class SimServer {
 public:
  struct Stats {
    uint64_t bytes_in = 0;
    uint64_t replies_sent = 0;
    uint64_t replies_undeliverable = 0;  // the connection had gone, or the pty was full
    uint64_t connections = 0;            // TCP connections accepted so far
    uint64_t saves = 0;                  // state file saves handed to the saver
    uint64_t save_failures = 0;
    // How late replies were written, against the instant the timing rule
    // gives (wake-up latency of the loop): sum and worst case.
    Duration lateness_total{};
    Duration lateness_max{};
    uint64_t tap_bytes_dropped = 0;  // the tap's reader was too slow (or absent)
  };

  // Opens the pty and/or the listener (throws client::LinkError
  // PortUnavailable, lec6::InvalidArgument when neither is asked for). The
  // bus must outlive the server and is only touched by run()'s thread.
  SimServer(sim::Bus& bus, SimServerOptions options);
  ~SimServer();
  SimServer(const SimServer&) = delete;
  SimServer& operator=(const SimServer&) = delete;

  // Serves until stop(); then saves the state a last time (if any) and
  // returns. Throws on an unrecoverable descriptor error.
  void run();

  // Makes run() return soon. Thread-safe and async-signal-safe.
  void stop() noexcept;

  const transport::Pty* pty() const { return pty_.get(); }
  const transport::Pty* tap() const { return tap_.get(); }
  const transport::TcpListener* tcp() const { return listener_.get(); }
  // Where masters connect: the pty's client path and/or the TCP URL.
  std::string endpoints() const;

  // A snapshot, for tests (read after run() returned, or racy).
  Stats stats() const;

 private:
  struct Impl;
  sim::Bus& bus_;
  SimServerOptions options_;
  std::unique_ptr<transport::Pty> pty_;
  std::unique_ptr<transport::Pty> tap_;
  std::unique_ptr<transport::TcpListener> listener_;
  transport::UniqueFd stop_fd_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lec6::twin
