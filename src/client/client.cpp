#include "lec6/client/client.hpp"

#include "lec6/client/rtu_master.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <string>
#include <vector>

#include "lec6/lec/explain.hpp"
#include "lec6/lec/memory_map.hpp"

namespace lec6::client {
namespace {

using namespace modbus;

std::string join(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& l : lines) out += (out.empty() ? "" : "; ") + l;
  return out;
}

template <typename T>
const T& expect_reply(const Response& r, std::string_view what) {
  if (const T* t = std::get_if<T>(&r)) return *t;
  throw TransportError(TransportErrorKind::Framing,
                       fmt::format("unexpected reply type to {}", what));
}

void check_step_number(unsigned step) {
  if (step >= lec::kStepCount) {
    throw InvalidRequest(fmt::format("step {} does not exist: steps are numbered 0 to 63", step));
  }
}

void check_record(const lec::StepData& data, std::optional<unsigned> step) {
  if (data.is_blank() && step) return;  // a blank step is a legal (unregistered) record
  const auto issues = lec::validation_messages(data, step);
  if (!issues.empty()) throw InvalidRequest(join(issues));
}

}  // namespace

namespace {

RtuOptions rtu_options(const ClientOptions& o) {
  RtuOptions r;
  r.silent_interval_k = o.silent_interval_k;
  r.delay_td = o.delay_td;
  r.timeout_margin = o.timeout_margin;
  r.wait_for_silence = o.wait_for_silence;
  r.reply_spin = o.reply_spin;
  r.trace = o.trace;
  r.interrupted = o.interrupted;
  return r;
}

// The line settings of ClientOptions act through the RtuMaster a Client makes
// on a Link; a Client given a Master would silently drop them.
const ClientOptions& refuse_line_settings(const ClientOptions& o) {
  const ClientOptions defaults;
  std::vector<std::string> set;
  if (o.silent_interval_k != defaults.silent_interval_k) set.emplace_back("silent_interval_k");
  if (o.delay_td != defaults.delay_td) set.emplace_back("delay_td");
  if (o.timeout_margin != defaults.timeout_margin) set.emplace_back("timeout_margin");
  if (o.wait_for_silence != defaults.wait_for_silence) set.emplace_back("wait_for_silence");
  if (o.reply_spin != defaults.reply_spin) set.emplace_back("reply_spin");
  if (o.trace) set.emplace_back("trace");
  if (o.interrupted) set.emplace_back("interrupted");
  if (!set.empty()) {
    throw InvalidArgument(fmt::format(
        "ClientOptions {} set for a Client on a Master: they act only on a Client made on a "
        "Link; give them to the master instead (RtuOptions, twin::PortOptions)",
        fmt::join(set, ", ")));
  }
  return o;
}

}  // namespace

Client::Client(Link& link, ClientOptions options)
    : owned_(std::make_unique<RtuMaster>(link, rtu_options(options))),
      master_(*owned_),
      options_(std::move(options)) {}

Client::Client(Master& master, ClientOptions options)
    : master_(master), options_(refuse_line_settings(options)) {}

Client::~Client() = default;

LinkStats Client::stats() const {
  LinkStats s = master_.stats();
  s.retries += retries_;
  s.exceptions += exceptions_;
  return s;
}

Response Client::transact(const Request& request, Retry retry, std::optional<uint8_t> id) {
  // Refuse what the memory map refuses before it reaches the line. The input
  // mode is the controller's business (it answers 02), so assume serial mode.
  if (auto refusal = lec::check_request(request, true)) {
    throw InvalidRequest(fmt::format("refused before sending: {} (use `lec raw` to send it anyway)",
                                     refusal->reason));
  }
  const RequestFrame frame{id.value_or(options_.id), request};
  if (frame.id == kBroadcastId && !is_write(request)) {
    throw InvalidRequest(
        "ID 0 is broadcast: controllers do not answer it, so a read cannot work; only writes can "
        "be broadcast (e.g. `lec --id 0 serial on`, `lec --id 0 hold on`, `lec --id 0 stop`)");
  }
  const int attempts = retry == Retry::Safe ? 1 + std::max(0, options_.retries) : 1;
  for (int attempt = 1;; ++attempt) {
    try {
      ResponseFrame reply = master_.exchange(frame);
      if (const auto* ex = std::get_if<ExceptionResponse>(&reply.pdu)) {
        ++exceptions_;
        throw ControllerException(
            ex->code, fmt::format("controller ID {} refused \"{}\": {}", frame.id,
                                  lec::explain_request(frame), lec::explain_exception(ex->code)));
      }
      return std::move(reply.pdu);
    } catch (const TransportError& e) {
      const bool line_fault = e.kind() == TransportErrorKind::Timeout ||
                              e.kind() == TransportErrorKind::Crc ||
                              e.kind() == TransportErrorKind::Framing;
      if (!line_fault || attempt >= attempts) throw;
      ++retries_;
    }
  }
}

ResponseFrame Client::transact_raw(const RequestFrame& frame) {
  return master_.exchange(frame);
}

void Client::broadcast(const Request& request) {
  if (!is_write(request)) {
    throw InvalidRequest("a broadcast (ID 0) only carries writes (05, 0F, 10): reads get no reply");
  }
  master_.exchange(RequestFrame{kBroadcastId, request});
}

// ---- reads ------------------------------------------------------------------

std::vector<uint16_t> Client::read_registers(uint16_t start, uint16_t count) {
  const auto reply = transact(ReadRegistersRequest{start, count});
  return expect_reply<ReadRegistersResponse>(reply, "read").values;
}

lec::StateData Client::read_state() {
  return lec::StateData::from_registers(read_registers(lec::kStateData, lec::kStateDataRegisters));
}

lec::StatusFlags Client::read_flags() {
  const auto reply = transact(
      ReadBitsRequest{FunctionCode::ReadInputs, lec::kStatusInputs, lec::kStatusInputCount});
  return lec::normalise_alarm(
      lec::StatusFlags::from_packed(expect_reply<ReadBitsResponse>(reply, "read flags").packed),
      options_.alarm_polarity);
}

lec::ControlFlags Client::read_controls() {
  // Y10–Y30 in one read: 33 coils inside the coil area (field practice).
  const auto reply = transact(ReadBitsRequest{FunctionCode::ReadCoils, 0x10, 33});
  const auto& bits = expect_reply<ReadBitsResponse>(reply, "read coils");
  lec::ControlFlags c;
  for (unsigned i = 0; i < 16; ++i) {
    if (bits.bit(i)) c.y10_1f = static_cast<uint16_t>(c.y10_1f | (1U << i));
  }
  c.serial_mode = bits.bit(32);
  return c;
}

lec::StepData Client::read_step(unsigned step) {
  check_step_number(step);
  return lec::StepData::from_registers(
      read_registers(lec::step_address(step), lec::StepData::kRegisters));
}

std::array<lec::StepData, lec::kStepCount> Client::read_all_steps() {
  std::array<lec::StepData, lec::kStepCount> steps{};
  constexpr unsigned kPerRead =
      kMaxReadRegisters / lec::StepData::kRegisters;  // 7 steps, 112 registers
  for (unsigned first = 0; first < lec::kStepCount; first += kPerRead) {
    const unsigned n = std::min<unsigned>(kPerRead, lec::kStepCount - first);
    const auto regs = read_registers(lec::step_address(first),
                                     static_cast<uint16_t>(n * lec::StepData::kRegisters));
    for (unsigned i = 0; i < n; ++i) {
      steps[first + i] = lec::StepData::from_registers(
          std::span(regs).subspan(i * lec::StepData::kRegisters, lec::StepData::kRegisters));
    }
  }
  return steps;
}

lec::StepData Client::read_direct() {
  return lec::StepData::from_registers(read_registers(lec::kDirectData, lec::StepData::kRegisters));
}

lec::AlarmHistory Client::read_alarms() {
  return lec::AlarmHistory::from_registers(
      read_registers(lec::kAlarmHistory, lec::kAlarmHistoryRegisters));
}

lec::EquipmentName Client::read_name() {
  return lec::EquipmentName::from_registers(
      read_registers(lec::kEquipmentName, lec::kEquipmentNameRegisters));
}

uint16_t Client::echo(uint16_t data) {
  const auto reply = transact(EchoRequest{0, data});
  const auto& e = expect_reply<EchoResponse>(reply, "echo");
  if (e.data != data) {
    throw TransportError(TransportErrorKind::Framing,
                         fmt::format("echo returned {:04X}h for {:04X}h", e.data, data));
  }
  return e.data;
}

// ---- writes -----------------------------------------------------------------

void Client::write_coil(lec::Coil coil, bool on) {
  // Coils are levels: writing the same level twice is harmless, so retries are safe.
  transact(WriteCoilRequest{lec::address(coil), on ? kCoilOn : kCoilOff});
}

void Client::select_step(unsigned step) {
  check_step_number(step);
  std::array<bool, 8> bits{};
  for (unsigned i = 0; i < 6; ++i) bits[i] = (step >> i) & 1U;
  transact(WriteCoilsRequest::of(lec::address(lec::Coil::IN0), bits));
}

void Client::write_registers(uint16_t start, std::span<const uint16_t> values, Retry retry) {
  transact(WriteRegistersRequest::of(start, values), retry);
}

void Client::write_step(unsigned step, const lec::StepData& data) {
  check_step_number(step);
  check_record(data, step);
  const auto regs = data.to_registers();
  write_registers(lec::step_address(step), regs);
}

void Client::write_step_registers(unsigned step, const lec::StepData& data, unsigned first,
                                  unsigned count, Retry retry) {
  check_step_number(step);
  check_record(data, step);
  if (first + count > lec::StepData::kRegisters || count == 0) {
    throw InvalidRequest(fmt::format("registers {}+{} are outside a step record", first, count));
  }
  const auto regs = data.to_registers();
  write_registers(static_cast<uint16_t>(lec::step_address(step) + first),
                  std::span(regs).subspan(first, count), retry);
}

void Client::write_direct(const lec::StepData& data) {
  write_direct_registers(data, 0, lec::StepData::kRegisters);
}

void Client::write_direct_registers(const lec::StepData& data, unsigned first, unsigned count) {
  check_record(data, std::nullopt);
  if (first + count > lec::StepData::kRegisters || count == 0) {
    throw InvalidRequest(
        fmt::format("registers {}+{} are outside the direct-operation record", first, count));
  }
  const auto regs = data.to_registers();
  write_registers(static_cast<uint16_t>(lec::kDirectData + first),
                  std::span(regs).subspan(first, count));
}

void Client::write_direct_start(Retry retry) {
  const uint16_t start[] = {lec::kDirectStartValue};
  write_registers(lec::kDirectStart, start, retry);
}

}  // namespace lec6::client
