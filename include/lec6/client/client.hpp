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
// The wire is a Master's business (master.hpp): Modbus RTU with the manual's
// timing (RtuMaster, made for you when the Client is given a Link), or Modbus
// TCP (transport::ModbusTcpMaster), e.g. through `lec serve`.

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "lec6/client/errors.hpp"
#include "lec6/client/link.hpp"
#include "lec6/client/master.hpp"
#include "lec6/lec/alarm_check.hpp"
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

struct ClientOptions {
  uint8_t id = 1;
  int retries = 2;  // for Retry::Safe requests
  // How this controller reports X4F ALARM (lec/alarm_check.hpp): read_flags()
  // turns an active-low controller's X4F into the manual's meaning, so every
  // caller (moves, status, doctor) sees 1 = alarm. Not a line setting: also on a Master.
  lec::AlarmPolarity alarm_polarity = lec::AlarmPolarity::ActiveHigh;
  // For a Client made on a Link (Modbus RTU) only: the line and the
  // controller's settings, see RtuOptions. A Client given a Master refuses them
  // (InvalidArgument, naming them) when they differ from these defaults: the
  // master has its own (RtuOptions, twin::PortOptions).
  unsigned silent_interval_k = 1;                           // the controller's "Silent INT"
  Duration delay_td = std::chrono::milliseconds(5);         // the controller's "Min Resp delay"
  Duration timeout_margin = std::chrono::milliseconds(50);  // added to Tx
  bool wait_for_silence = true;                             // see RtuOptions
  Duration reply_spin{};                                    // see RtuOptions
  TraceSink trace{};                                        // every frame, when set
  std::function<bool()> interrupted{};                      // Ctrl-C, see RtuOptions
};

// Thread safety: one thread at a time (a Client owns its line while a call
// runs). To share a line between threads, give each thread its own Client on
// one client::SharedMaster (shared_master.hpp); lec serve shares a line with
// its scheduler instead.
// Lifetime: a Client made on a Link keeps a reference to the Link (its own
// RtuMaster is inside it); one given a Master keeps a reference to the Master.
// Either must outlive the Client. ClientOptions' callbacks (trace, interrupted)
// are called on the thread making the call and must stay valid as long.
class Client {
 public:
  // Modbus RTU on a byte link (serial port, RTU over TCP, the in-process twin).
  explicit Client(Link& link, ClientOptions options = {});
  // Any other way to reach controllers (Modbus TCP, lec serve's scheduler).
  // The master must outlive the Client.
  explicit Client(Master& master, ClientOptions options = {});
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  // ---- raw ----------------------------------------------------------------
  // Sends a request to `options.id` (or `id` when given) and returns the
  // verified reply. An exception reply throws ControllerException. A read or
  // echo to ID 0 (broadcast: nobody answers) throws InvalidRequest unsent.
  modbus::Response transact(const modbus::Request& request, Retry retry = Retry::Safe,
                            std::optional<uint8_t> id = std::nullopt);
  // Like transact() but returns exception replies instead of throwing, and
  // performs no address checks: for `lec raw`.
  modbus::ResponseFrame transact_raw(const modbus::RequestFrame& frame);
  // Sends to ID 0: no reply; waits Tx after it.
  void broadcast(const modbus::Request& request);

  // ---- typed reads ----------------------------------------------------------
  lec::StateData read_state();
  lec::StatusFlags read_flags();  // X4F in the manual's meaning (ClientOptions::alarm_polarity)
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
  // Retry::Never when the caller decides what a lost reply means (a restore
  // reads the step back instead of writing EEPROM twice).
  void write_step_registers(unsigned step, const lec::StepData& data, unsigned first,
                            unsigned count, Retry retry = Retry::Safe);
  void write_direct(const lec::StepData& data);  // D9102–D9111, validated
  void write_direct_registers(const lec::StepData& data, unsigned first, unsigned count);
  // D9100 ← 0x0100. Never resent blindly when `relative` (INC): see start_direct().
  void write_direct_start(Retry retry);
  void write_registers(uint16_t start, std::span<const uint16_t> values, Retry retry = Retry::Safe);

  // ---- line -----------------------------------------------------------------
  Master& master() noexcept { return master_; }
  const Clock& clock() const noexcept { return master_.clock(); }
  const ClientOptions& options() const noexcept { return options_; }
  void set_id(uint8_t id) noexcept { options_.id = id; }
  const modbus::LineTiming& timing() const noexcept { return master_.line_timing(); }
  // The master's counters with this client's retries and exceptions.
  LinkStats stats() const;
  // The round trip of the last successful transaction (first byte sent → reply complete).
  Duration last_round_trip() const { return master_.last_round_trip(); }
  // When the last successful transaction was on the wire (Master::last_wire_times).
  std::optional<WireTimes> last_wire_times() const { return master_.last_wire_times(); }
  // Waits until `t` without a transaction (Master::idle_until).
  void idle_until(TimePoint t) { master_.idle_until(t); }

 private:
  std::unique_ptr<Master> owned_;  // the RtuMaster of a Client made on a Link
  Master& master_;
  ClientOptions options_;
  uint64_t retries_ = 0;
  uint64_t exceptions_ = 0;
};

}  // namespace lec6::client
