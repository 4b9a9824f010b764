#pragma once
// lec doctor's probes (private to the CLI): what it asks the line, in order,
// filling client::doctor::Observations, which client/doctor judges. They
// reach the line only through a ProbeLine: a port opened at a baud rate, a
// clock and a way to wait. `lec doctor` gives them the serial port and the
// steady clock (cmd_doctor.cpp); the tests give them a twin::VirtualLine and
// a VirtualClock, so every scenario runs in no wall time
// (tests/cli/doctor_probes_test.cpp).
//
//   doctor_probes::probe_line(line, settings, ids, fix, echo_option, obs,
//                             [&] { /* the adapter's latency timer (sysfs) */ });

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "lec6/client/doctor.hpp"
#include "lec6/lec/alarm_check.hpp"
#include "lec6/twin/open_port.hpp"

namespace lec6::cli::doctor_probes {

// The line the probes ask.
struct ProbeLine {
  // The port opened anew at `baud`, echo discarded or not (the first probes
  // want to see an echo). Throws what open_port throws.
  std::function<std::unique_ptr<twin::OpenPort>(uint32_t baud, bool discard_echo)> open;
  // Budgets and round trips are measured on it; `wait` lets time pass on it
  // (sleeps on the steady clock, advances a virtual one).
  const Clock* clock = nullptr;
  std::function<void(Duration)> wait;
  // Ctrl-C: every probe ends at its next exchange.
  std::function<bool()> interrupted = [] { return false; };
};

// What the user told lec about the line (the global options).
struct ProbeSettings {
  uint32_t baud = 38400;  // tried first
  Duration reply_margin = std::chrono::milliseconds(50);
  unsigned silent_interval_k = 1;
  Duration delay_td = std::chrono::milliseconds(5);
  lec::AlarmPolarity alarm_polarity = lec::AlarmPolarity::ActiveHigh;
};

// What --fix may change. Serial mode only on the IDs named: a controller
// driven through parallel I/O ignores its PLC's HOLD and RESET once Y30 = 1
// (manual, footnote on serial mode), so the doctor never takes one away
// from its PLC unless told (the report names the command that would).
struct Fix {
  bool on = false;
  std::vector<uint8_t> serial_ids;
  bool may_set_serial(uint8_t id) const;
};

// Every check's deadline (the whole run stays within the sum, about 25 s at
// worst: six baud rates of 32 IDs at 9600-like windows, then the rest).
inline constexpr Duration kListen = std::chrono::milliseconds(500);
inline constexpr Duration kScanMargin = std::chrono::milliseconds(20);  // beyond Tx: a USB lump
inline constexpr Duration kSearchBudget = std::chrono::seconds(18);
inline constexpr Duration kBurstBudget = std::chrono::seconds(3);
inline constexpr int kBurstExchanges = 200;
inline constexpr int kNoisyRescans = 4;

// What the user asked, as the judgement needs it, before the probes fill in
// what they saw: the port as named, the IDs, --echo, --fix, lec's timing.
client::doctor::Observations asked(std::string port, std::string id_range, bool echo_option,
                                   bool fix, const ProbeSettings& s);

// 1-8 on a line lec owns: the baud and IDs (listening for another master
// first), whether echo discard works, a burst of reads (noise, timing,
// duplicates), the controllers' Silent INT; then, when something answered,
// `before_controllers` (the caller's: the adapter's latency timer in sysfs)
// and each controller's state through the port at the found baud, its echo
// discarded when one was seen or `echo_option` (--echo) says so. Fills `obs`.
void probe_line(const ProbeLine& line, const ProbeSettings& s, const std::vector<uint8_t>& ids,
                const Fix& fix, bool echo_option, client::doctor::Observations& obs,
                const std::function<void()>& before_controllers = {});

// 8. Each controller's state, read only (--fix: serial mode on where allowed,
// resettable alarms reset), through `port`.
void read_controllers(twin::OpenPort& port, const ProbeSettings& s, const std::vector<uint8_t>& ids,
                      const Fix& fix, const std::function<bool()>& interrupted,
                      client::doctor::Observations& obs);

}  // namespace lec6::cli::doctor_probes
