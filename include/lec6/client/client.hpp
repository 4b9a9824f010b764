#pragma once
// The client side of the LEC□6 protocol: typed reads and writes of the memory
// map over any Link, at the speed of the wire.
//
//   lec6::client::Client c(link, {.id = 1});
//   auto state = c.read_state();          // D9000–D9006
//   auto flags = c.read_flags();          // X40–X4F
//   c.write_coil(lec6::lec::Coil::SVON, true);
//
// Every call is one or more Modbus transactions. Errors are thrown:
// TransportError (line), ControllerException (exception reply),
// InvalidRequest (refused before sending). See errors.hpp.
//
// Timing (digest §1): before sending, the line must have been silent for Ts;
// a reply completes the moment its expected length is in; it times out at
// Tx + margin after the query; after a broadcast the client waits Tx.

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "lec6/client/link.hpp"
#include "lec6/client/transaction.hpp"
#include "lec6/lec/alarms.hpp"
#include "lec6/lec/equipment_name.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/lec/state_data.hpp"
#include "lec6/lec/step_data.hpp"
#include "lec6/modbus/pdu.hpp"

namespace lec6::client {

// Whether a request may be sent again after a lost reply.
enum class Retry {
  Safe,   // reads, absolute writes: repeating them changes nothing
  Never,  // starts of relative moves: a repeat would move twice
};

struct TraceEvent {
  bool outgoing;  // true: sent, false: received
  TimePoint at;
  std::span<const uint8_t> bytes;
  std::string explanation;  // in LEC terms
};

struct ClientOptions {
  uint8_t id = 1;
  unsigned silent_interval_k = 1;              // the controller's "Silent INT"
  Duration delay_td = milliseconds(5);         // the controller's "Min Resp delay"
  Duration timeout_margin = milliseconds(50);  // added to Tx
  int retries = 2;                             // for Retry::Safe requests
  // Wait for Ts of line silence before each query (manual §8.2: a controller
  // delimits frames by it). Keep it on for any real RS485 line. Off only for
  // peers that frame by length (a `--timing fast` twin, software benchmarks),
  // where it would measure the line rule rather than the software.
  bool wait_for_silence = true;
  std::function<void(const TraceEvent&)> trace;  // every frame, when set
};

// Counters for a session: what the line did.
struct LinkStats {
  uint64_t transactions = 0;
  uint64_t retries = 0;
  uint64_t timeouts = 0;
  uint64_t crc_errors = 0;
  uint64_t framing_errors = 0;
  uint64_t exceptions = 0;
  uint64_t bytes_discarded = 0;
};

class Client {
 public:
  Client(Link& link, ClientOptions options = {});

  // ---- raw ----------------------------------------------------------------
  // Sends a request to `options.id` (or `id` when given) and returns the
  // verified reply. An exception reply throws ControllerException.
  modbus::Response transact(const modbus::Request& request, Retry retry = Retry::Safe,
                            std::optional<uint8_t> id = std::nullopt);
  // Like transact() but returns exception replies instead of throwing, and
  // performs no address checks: for `lec raw`.
  modbus::ResponseFrame transact_raw(const modbus::RequestFrame& frame);
  // Sends to ID 0: no reply; waits Tx after it.
  void broadcast(const modbus::Request& request);

  // ---- typed reads ----------------------------------------------------------
  lec::StateData read_state();
  lec::StatusFlags read_flags();
  lec::ControlFlags read_controls();
  lec::StepData read_step(unsigned step);
  std::array<lec::StepData, lec::kStepCount> read_all_steps();
  lec::StepData read_direct();
  lec::AlarmHistory read_alarms();
  lec::EquipmentName read_name();
  std::vector<uint16_t> read_registers(uint16_t start, uint16_t count);
  uint16_t echo(uint16_t data);

  // ---- typed writes ---------------------------------------------------------
  void write_coil(lec::Coil coil, bool on);
  void select_step(unsigned step);  // IN0–IN5 by FC0F at Y10, 8 points (manual §4.3)
  // Writes a whole step (validated first: a step is never left invalid).
  void write_step(unsigned step, const lec::StepData& data);
  // Writes registers [first, first + count) of a step record from `data`.
  void write_step_registers(unsigned step, const lec::StepData& data, unsigned first,
                            unsigned count);
  void write_direct(const lec::StepData& data);  // D9102–D9111, validated
  void write_direct_registers(const lec::StepData& data, unsigned first, unsigned count);
  // D9100 ← 0x0100. Never resent blindly when `relative` (INC): see start_direct().
  void write_direct_start(Retry retry);
  void write_registers(uint16_t start, std::span<const uint16_t> values, Retry retry = Retry::Safe);

  // ---- line -----------------------------------------------------------------
  Link& link() noexcept { return link_; }
  const Clock& clock() const noexcept { return link_.clock(); }
  const ClientOptions& options() const noexcept { return options_; }
  void set_id(uint8_t id) noexcept { options_.id = id; }
  const modbus::LineTiming& timing() const noexcept { return timing_.line; }
  const LinkStats& stats() const noexcept { return stats_; }
  // The round trip of the last successful transaction (first byte sent → reply complete).
  Duration last_round_trip() const noexcept { return last_round_trip_; }

 private:
  modbus::ResponseFrame run_once(const modbus::RequestFrame& frame);
  void wait_for_silence();
  void trace(bool outgoing, TimePoint at, std::span<const uint8_t> bytes,
             const modbus::RequestFrame& request, const modbus::ResponseFrame* response);

  Link& link_;
  ClientOptions options_;
  TransactionTiming timing_;
  TimePoint line_busy_until_{};
  Duration guard_after_failure_{};  // silence required before the next query after a failure
  LinkStats stats_;
  Duration last_round_trip_{};
};

}  // namespace lec6::client
