#pragma once
// The twin's state file, kept up to date from the event loop without ever
// making the loop wait on the disk (twin/sim_server.hpp, SimServerOptions).
//
// The loop (one thread, the only one that touches the bus) asks check() at
// each turn; when the EEPROM has changed, a save is due at once the first
// time, then at most every `save_interval`. A due save snapshots the EEPROM
// on the loop's thread and hands the snapshot to a background thread, which
// writes it atomically (twin/state_file_io.hpp). A snapshot not yet written is
// replaced by a newer one: the newest state wins, nothing queues up.
//
// Thread safety: every member except the counters is called from the loop's
// thread only; saves() and failures() may be read from any thread.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "lec6/clock.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/sim/state_file.hpp"

namespace lec6::twin {

class StateSaver {
 public:
  struct Options {
    std::filesystem::path path;  // empty: nothing is saved, every call is a no-op
    Duration interval{};
    sim::EepromSet carry;  // controllers not on this bus, written back unchanged
    std::function<void(const std::string&)> warn;
  };

  StateSaver(const sim::Bus& bus, Options options);
  ~StateSaver();  // stop()
  StateSaver(const StateSaver&) = delete;
  StateSaver& operator=(const StateSaver&) = delete;

  // Starts the writer thread and takes the bus's current EEPROM as saved.
  void start();
  // Submits a save when one is due at `now`.
  void check(TimePoint now);
  // When check() must next be called for a pending save; nullopt: none pending.
  std::optional<TimePoint> due() const { return save_at_; }
  // The last save: when the EEPROM changed since the last one, or when the
  // file does not exist yet.
  void final_save(TimePoint now);
  // Writes what is pending, then ends the writer thread.
  void stop();

  uint64_t saves() const { return saves_; }
  uint64_t failures() const { return failures_; }

 private:
  uint64_t generation() const;
  sim::EepromSet snapshot() const;
  void submit(TimePoint now);
  void writer_loop();

  const sim::Bus& bus_;
  Options options_;

  uint64_t saved_generation_ = 0;
  std::optional<TimePoint> save_at_;
  TimePoint last_save_{};
  bool have_saved_ = false;

  std::thread writer_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::optional<sim::EepromSet> pending_;
  bool quit_ = false;

  std::atomic<uint64_t> saves_{0}, failures_{0};
};

}  // namespace lec6::twin
