#pragma once
// Over 450 lines: the four protocol harnesses share their checking helpers here.
// The fuzz harnesses' bodies, header-only so that the libFuzzer programs
// (fuzz/fuzz_*.cpp, clang only) and the ordinary regression test
// (tests/modbus/fuzz_regression_test.cpp, any compiler) run the same code on
// the same inputs.
//
// Each harness feeds one input to lec6 and checks properties that must hold
// for every input. A property that fails calls failure(): by default it
// prints the reason and aborts (libFuzzer then keeps the input as a crash);
// the regression test installs a handler that throws instead.
//
// Input formats (all byte strings; see docs/robustness.md):
//
//   reply:   [ctl][request ADU][reply byte stream]
//            ctl seeds the chunking of the stream. The request ADU is sized by
//            request_length(); when it does not decode to a request the
//            client could send, a fixed request chosen by ctl is used and the
//            whole rest is the reply stream.
//   request: [ctl][byte stream a master (or noise) put on the line]
//            ctl seeds the chunk sizes and gaps and picks the framer's mode.
//   twin:    [setup][record]*   record = [head][len][len body bytes]
//            head bit 7: append a valid CRC to a non-empty body;
//            head bits 4-6: the gap before the record (0 = same frame,
//            1 = 2 ms, 2 = 20 ms, 3 = 200 ms, 4 = 2 s, 5 = 30 s,
//            6 = toggle the EMG stop of ID 1 (head bit 0 = 0) or ID 2
//            (bit 0 = 1), then 5 ms, 7 = 1 ms). An empty body only waits.
//            setup bit 0: fast timing; bit 1: a workpiece at 250 mm;
//            bits 2-3: baud (38400, 9600, 115200, 230400).
//   steps:   a CSV (or, with a leading '{', JSON) step table.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <functional>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "lec6/client/errors.hpp"
#include "lec6/client/transaction.hpp"
#include "lec6/expected.hpp"
#include "lec6/lec/explain.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/lec/step_table.hpp"
#include "lec6/modbus/crc.hpp"
#include "lec6/modbus/framer.hpp"
#include "lec6/modbus/length.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/modbus/timing.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/sim/controller.hpp"

namespace lec6::fuzz {

using modbus::Bytes;

// ---- failure reporting --------------------------------------------------------

using FailureHandler = std::function<void(const std::string&)>;

inline FailureHandler& failure_handler() {
  static FailureHandler handler;
  return handler;
}

[[noreturn]] inline void failure(const std::string& what) {
  if (auto& h = failure_handler()) {
    h(what);
    throw std::logic_error(what);  // the handler must not return; make sure
  }
  std::fprintf(stderr, "lec6 fuzz property violated: %s\n", what.c_str());
  std::abort();
}

inline void check(bool ok, const char* what) {
  if (!ok) failure(what);
}

inline void check(bool ok, const std::string& what) {
  if (!ok) failure(what);
}

// ---- helpers ------------------------------------------------------------------

// A small deterministic generator (splitmix64), seeded from the input, so a
// replay of an input does exactly what the fuzzer did.
class Rng {
 public:
  explicit Rng(uint64_t seed) : s_(seed) {}
  uint64_t next() {
    uint64_t z = (s_ += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  std::size_t below(std::size_t n) { return n ? static_cast<std::size_t>(next() % n) : 0; }

 private:
  uint64_t s_;
};

inline bool contains(std::span<const uint8_t> hay, std::span<const uint8_t> needle) {
  return std::search(hay.begin(), hay.end(), needle.begin(), needle.end()) != hay.end();
}

inline bool reply_matches_request(const modbus::Response& r, const modbus::Request& q) {
  const auto fc = modbus::function_of(q);
  if (const auto* ex = std::get_if<modbus::ExceptionResponse>(&r))
    return ex->raw_function == static_cast<uint8_t>(fc);
  switch (fc) {
    case modbus::FunctionCode::ReadCoils:
    case modbus::FunctionCode::ReadInputs: {
      const auto* b = std::get_if<modbus::ReadBitsResponse>(&r);
      const auto& rq = std::get<modbus::ReadBitsRequest>(q);
      return b && b->function == fc && b->packed.size() == (rq.count + 7u) / 8u;
    }
    case modbus::FunctionCode::ReadRegisters: {
      const auto* v = std::get_if<modbus::ReadRegistersResponse>(&r);
      return v && v->values.size() == std::get<modbus::ReadRegistersRequest>(q).count;
    }
    case modbus::FunctionCode::WriteCoil:
      return std::holds_alternative<modbus::WriteCoilResponse>(r);
    case modbus::FunctionCode::Echo:
      return std::holds_alternative<modbus::EchoResponse>(r);
    case modbus::FunctionCode::WriteCoils:
    case modbus::FunctionCode::WriteRegisters: {
      const auto* w = std::get_if<modbus::WriteMultipleResponse>(&r);
      return w && w->function == fc;
    }
  }
  return false;
}

// Requests the client really sends, for inputs whose request part does not decode.
inline modbus::Request fixed_request(unsigned which) {
  using namespace modbus;
  switch (which % 8) {
    case 0:
      return ReadRegistersRequest{lec::kStateData, lec::kStateDataRegisters};
    case 1:
      return ReadBitsRequest{FunctionCode::ReadInputs, lec::kStatusInputs, lec::kStatusInputCount};
    case 2:
      return ReadBitsRequest{FunctionCode::ReadCoils, 0x10, 33};
    case 3:
      return WriteCoilRequest{0x19, kCoilOn};
    case 4:
      return EchoRequest{0, 0x5AA5};
    case 5: {
      const bool bits[8] = {false, true, false, false, false, false, false, false};
      return WriteCoilsRequest::of(0x10, bits);
    }
    case 6: {
      const uint16_t v[16] = {1, 500, 0, 15000, 5000, 5000, 0, 0, 20, 100, 0, 0, 0, 0, 0, 100};
      return WriteRegistersRequest::of(0x0400, v);
    }
    default:
      return ReadRegistersRequest{lec::kStepData, 112};
  }
}

// ---- harness 1: reply decoding + the client's framer -------------------------

inline void reply_one(const uint8_t* data, std::size_t size) {
  if (size < 1) return;
  const uint8_t ctl = data[0];
  std::span<const uint8_t> rest(data + 1, size - 1);

  // The request the client sent.
  std::optional<modbus::RequestFrame> request;
  std::span<const uint8_t> stream = rest;
  const auto qlen = modbus::request_length(rest);
  if (qlen.status == modbus::FrameLength::Status::Known && qlen.bytes <= rest.size()) {
    auto q = modbus::decode_request(rest.first(qlen.bytes));
    if (q && q->id != modbus::kBroadcastId && modbus::encode_request(*q)) {
      request = *q;
      stream = rest.subspan(qlen.bytes);
    }
  }
  if (!request)
    request = modbus::RequestFrame{static_cast<uint8_t>(1 + (ctl >> 5)), fixed_request(ctl >> 2)};

  // decode_response on the whole stream: structural, and canonical when it succeeds.
  if (auto d = modbus::decode_response(stream)) {
    check(modbus::crc_ok(stream), "decode_response accepted a frame with a bad CRC");
    const Bytes again = modbus::encode_response(*d);
    check(std::equal(again.begin(), again.end(), stream.begin(), stream.end()),
          "decode_response then encode_response does not give the frame back");
    const auto len = modbus::response_length(stream);
    check(len.status == modbus::FrameLength::Status::Known && len.bytes == stream.size(),
          "response_length disagrees with a frame decode_response accepted");
    (void)lec::explain_response(*d, &*request);
  }
  (void)lec::explain_bytes(stream, lec::FrameRole::Reply);
  (void)modbus::response_length(stream);

  // The bare framer, byte by byte: every byte is either dropped, buffered or
  // part of the frame; a completed frame is a verbatim, CRC-checked candidate.
  {
    modbus::ClientFramer framer;
    framer.expect(request->id, request->pdu);
    const std::size_t normal = modbus::expected_response_length(request->pdu);
    std::size_t fed = 0;
    for (uint8_t b : stream) {
      ++fed;
      const auto status = framer.feed(std::span<const uint8_t>(&b, 1));
      if (status == modbus::ClientFramer::Status::Complete) {
        const auto f = framer.frame();
        check(f.size() == normal || f.size() == modbus::kExceptionLength,
              "framer completed a frame of a wrong length");
        check(modbus::crc_ok(f), "framer completed a frame with a bad CRC");
        check(f[0] == request->id, "framer completed a frame from another ID");
        check((f[1] & 0x7F) == static_cast<uint8_t>(modbus::function_of(request->pdu)),
              "framer completed a frame of another function");
        // Bytes after the frame may still be buffered (a long candidate failed its
        // CRC and a shorter frame inside it lined up).
        check(framer.discarded() + framer.buffered() == fed, "framer lost or invented bytes");
        check(framer.bytes_wanted() == 0, "bytes_wanted() after completion");
        check(contains(stream, f), "framer completed a frame that is not in the stream");
        break;
      }
      check(framer.discarded() + framer.buffered() == fed, "framer lost or invented bytes");
      check(framer.bytes_wanted() >= 1, "bytes_wanted() is 0 while incomplete");
      check(framer.buffered() < modbus::kMaxAdu, "framer buffered more than a frame");
    }
  }

  // The whole transaction, fed in chunks as a port delivers them.
  client::TransactionTiming timing;
  client::Transaction tx(*request, timing);
  TimePoint t = TimePoint{} + std::chrono::milliseconds(1000);
  tx.sent(t);
  Rng rng(ctl);
  std::size_t at = 0;
  while (at < stream.size() && tx.step() == client::Transaction::Step::Receive) {
    const std::size_t n =
        std::min<std::size_t>(stream.size() - at, 1 + rng.below(rng.below(4) == 0 ? 64 : 4));
    t += to_duration(FractionalMilliseconds(0.1));
    tx.received(stream.subspan(at, n), t);
    at += n;
  }
  if (tx.step() == client::Transaction::Step::Receive) tx.timed_out(tx.deadline());
  check(tx.step() == client::Transaction::Step::Done ||
            tx.step() == client::Transaction::Step::Failed,
        "transaction neither done nor failed after its deadline");
  if (tx.step() == client::Transaction::Step::Done) {
    const auto& r = tx.response();
    check(r.id == request->id, "transaction accepted a reply from another ID");
    check(reply_matches_request(r.pdu, request->pdu),
          "transaction accepted a reply that does not fit the request");
    const Bytes encoded = modbus::encode_response(r);
    check(contains(stream.first(at), encoded),
          "transaction accepted a reply that is not in the stream");
  } else {
    const auto k = tx.error_kind();
    check(k == client::TransportErrorKind::Timeout || k == client::TransportErrorKind::Crc ||
              k == client::TransportErrorKind::Framing,
          "transaction failed with a kind the line cannot cause");
    check(!tx.error().empty(), "transaction failed without a message");
    if (k == client::TransportErrorKind::Timeout)
      check(stream.empty(), "bytes arrived but the failure is a timeout");
  }
}

// ---- harness 2: request decoding + the controller's framer ---------------------

inline void request_one(const uint8_t* data, std::size_t size) {
  if (size < 1) return;
  const uint8_t ctl = data[0];
  std::span<const uint8_t> stream(data + 1, size - 1);

  if (auto d = modbus::decode_request(stream)) {
    check(modbus::crc_ok(stream), "decode_request accepted a frame with a bad CRC");
    const auto len = modbus::request_length(stream);
    check(len.status == modbus::FrameLength::Status::Known && len.bytes == stream.size(),
          "request_length disagrees with a frame decode_request accepted");
    if (auto again = modbus::encode_request(*d)) {
      check(*again == Bytes(stream.begin(), stream.end()),
            "decode_request then encode_request differs");
    }
    (void)lec::explain_request(*d);
    for (bool serial : {false, true}) {
      if (auto refusal = lec::check_request(d->pdu, serial)) {
        check(refusal->code != modbus::ExceptionCode::IllegalFunction,
              "check_request answers 01 to a known function");
        check(!refusal->reason.empty(), "a refusal without a reason");
      }
    }
  }
  (void)lec::explain_bytes(stream, lec::FrameRole::Request);

  // The controller's framer: frames are the stream cut in pieces, in order,
  // nothing lost but what overflowed, nothing longer than a frame can be.
  static constexpr uint32_t kBauds[] = {38400, 9600, 115200, 230400};
  modbus::LineTiming line{kBauds[ctl & 3]};
  const Duration ts = line.silent_interval();
  modbus::DeviceFramer framer(
      ts, (ctl & 4) != 0 ? modbus::FrameEnd::LengthOrSilence : modbus::FrameEnd::Silence);
  Rng rng(ctl);
  TimePoint t = TimePoint{} + std::chrono::milliseconds(1000);
  Bytes joined;
  auto take = [&](TimePoint now) {
    while (auto f = framer.poll(now)) {
      check(!f->bytes.empty(), "device framer produced an empty frame");
      check(f->bytes.size() <= modbus::kMaxAdu + 1, "device framer produced an oversized frame");
      check(f->end_of_query <= now, "device framer completed a frame in the future");
      joined.insert(joined.end(), f->bytes.begin(), f->bytes.end());
    }
  };
  std::size_t at = 0;
  while (at < stream.size()) {
    const std::size_t n = std::min<std::size_t>(stream.size() - at, 1 + rng.below(16));
    switch (rng.below(4)) {
      case 0:
        break;  // back to back
      case 1:
        t += ts / 2;
        break;  // inside a frame
      case 2:
        t += ts;
        break;  // exactly Ts: ends the frame
      default:
        t += ts + std::chrono::milliseconds(rng.below(5));
        break;  // a pause
    }
    t += line.wire_time(n);
    framer.feed(stream.subspan(at, n), t);
    at += n;
    if (rng.below(2)) take(t);
    if (auto d = framer.deadline()) check(*d >= t - ts, "device framer deadline in the past");
  }
  take(t + ts);
  check(!framer.deadline().has_value(), "device framer still holds bytes after Ts of silence");
  check(joined.size() + framer.overflowed() == stream.size(),
        "device framer lost or invented bytes");
  if (framer.overflowed() == 0) {
    check(std::equal(joined.begin(), joined.end(), stream.begin(), stream.end()),
          "device framer reordered or changed bytes");
  }
}

// ---- harness 3: the twin's whole request handling ----------------------------

namespace detail {

struct Snapshot {
  std::array<lec::StepData, sim::Eeprom::kSteps> steps{};
  lec::EquipmentName name;
  lec::ControlFlags control;
  std::vector<uint16_t> direct;
  bool operator==(const Snapshot&) const = default;
};

inline Snapshot snapshot(sim::Controller& c, TimePoint t) {
  Snapshot s;
  s.steps = c.eeprom().steps;
  s.name = c.eeprom().name;
  s.control = c.control();
  // A read changes nothing; it shows the direct-operation data (RAM).
  const auto r = c.handle(modbus::ReadRegistersRequest{lec::kDirectData, 16}, t);
  if (const auto* v = std::get_if<modbus::ReadRegistersResponse>(&r)) s.direct = v->values;
  return s;
}

// Whether a frame may change controller `id`: a good CRC, addressed to it or
// broadcast, and a write function.
inline bool may_write(std::span<const uint8_t> f, uint8_t id) {
  if (f.size() < 4 || f.size() > modbus::kMaxAdu || !modbus::crc_ok(f)) return false;
  if (f[0] != id && f[0] != modbus::kBroadcastId) return false;
  return f[1] == 0x05 || f[1] == 0x0F || f[1] == 0x10;
}

// Whether the bus owes a reply to a frame (digest §2–§3): good CRC, an ID on
// the bus, and a frame the controller understands or answers with 01/03.
inline bool owes_reply(std::span<const uint8_t> f, const std::vector<uint8_t>& ids) {
  if (f.size() < 4 || f.size() > modbus::kMaxAdu || !modbus::crc_ok(f)) return false;
  if (std::find(ids.begin(), ids.end(), f[0]) == ids.end()) return false;
  auto d = modbus::decode_request(f);
  if (d) return true;
  return d.error().kind == modbus::ErrorKind::UnknownFunction ||
         d.error().kind == modbus::ErrorKind::BadByteCount;
}

}  // namespace detail

inline void twin_one(const uint8_t* data, std::size_t size) {
  if (size < 1) return;
  const uint8_t setup = data[0];
  static constexpr uint32_t kBauds[] = {38400, 9600, 115200, 230400};
  sim::LineConfig line;
  line.line.baud = kBauds[(setup >> 2) & 3];
  line.timing = (setup & 1) ? sim::Timing::Fast : sim::Timing::Real;
  sim::ActuatorConfig config;
  if (setup & 2) config.workpiece_mm = 250.0;
  const Duration ts = line.line.silent_interval();

  TimePoint t = TimePoint{} + std::chrono::milliseconds(1000);
  sim::Bus bus(line);
  const std::vector<uint8_t> ids = {1, 2};
  for (uint8_t id : ids) bus.add(id, config, t);

  // A shadow of the bus's framer: the same bytes at the same times give the
  // same frames, so we know what the bus acted on.
  modbus::DeviceFramer shadow(ts, line.timing == sim::Timing::Fast
                                      ? modbus::FrameEnd::LengthOrSilence
                                      : modbus::FrameEnd::Silence);
  std::deque<modbus::Bytes> owed;  // frames that must be answered, in order
  std::vector<modbus::Bytes> since_snapshot;
  std::vector<detail::Snapshot> before;
  for (uint8_t id : ids) before.push_back(detail::snapshot(*bus.find(id), t));
  uint64_t frames = 0;

  auto settle = [&](TimePoint now) {
    bus.advance(now);
    while (auto f = shadow.poll(now)) {
      ++frames;
      if (detail::owes_reply(f->bytes, ids)) owed.push_back(f->bytes);
      since_snapshot.push_back(std::move(f->bytes));
    }
    check(bus.stats().frames == frames, "the bus and its shadow framer disagree on the frames");
    // Nothing changes without a good write frame addressed to the controller.
    for (std::size_t i = 0; i < ids.size(); ++i) {
      auto now_state = detail::snapshot(*bus.find(ids[i]), now);
      if (now_state == before[i]) continue;
      const bool allowed =
          std::any_of(since_snapshot.begin(), since_snapshot.end(),
                      [&](const modbus::Bytes& f) { return detail::may_write(f, ids[i]); });
      check(allowed,
            "a controller changed its EEPROM, coils or direct data without a valid write frame");
      before[i] = std::move(now_state);
    }
    since_snapshot.clear();
    // Every reply decodes, comes from an ID on the bus, answers the frame it
    // is owed to, and is accepted by the client's own transaction.
    for (auto& r : bus.take_replies(now)) {
      check(!owed.empty(), "the twin replied to a frame that is owed no reply");
      const modbus::Bytes query = std::move(owed.front());
      owed.pop_front();
      check(r.id == query[0] && !r.bytes.empty() && r.bytes[0] == query[0],
            "the twin replied with another ID");
      // Fast timing models no wire time; real timing does.
      check(line.timing == sim::Timing::Fast ? r.end == r.start : r.end > r.start,
            "a reply's wire time is wrong");
      auto decoded = modbus::decode_response(r.bytes);
      check(decoded.has_value(), "the twin sent a reply that does not decode");
      auto q = modbus::decode_request(query);
      if (!q) {
        check(std::holds_alternative<modbus::ExceptionResponse>(decoded->pdu),
              "the twin answered a malformed frame with a normal reply");
        continue;
      }
      check(reply_matches_request(decoded->pdu, q->pdu),
            "the twin's reply does not fit the request");
      if (!modbus::encode_request(*q)) continue;  // a count the client never sends
      client::TransactionTiming timing;
      timing.line = line.line;
      client::Transaction tx(*q, timing);
      tx.sent(r.start);
      tx.received(r.bytes, r.end);
      check(tx.step() == client::Transaction::Step::Done,
            "the client refuses the twin's reply to its own request");
    }
  };

  std::size_t at = 1;
  while (at + 2 <= size) {
    const uint8_t head = data[at];
    const std::size_t len = std::min<std::size_t>(data[at + 1], size - at - 2);
    Bytes body(data + at + 2, data + at + 2 + len);
    at += 2 + len;
    if ((head & 0x80) && !body.empty()) modbus::append_crc(body);
    switch ((head >> 4) & 7) {
      case 0:
        break;
      case 1:
        t += std::chrono::milliseconds(2);
        break;
      case 2:
        t += std::chrono::milliseconds(20);
        break;
      case 3:
        t += std::chrono::milliseconds(200);
        break;
      case 4:
        t += std::chrono::milliseconds(2000);
        break;
      case 5:
        t += std::chrono::milliseconds(30000);
        break;
      case 6: {
        settle(t);
        auto* c = bus.find(ids[head & 1]);
        c->set_estop(!c->status(t).estop(), t);
        t += std::chrono::milliseconds(5);
        break;
      }
      default:
        t += std::chrono::milliseconds(1);
        break;
    }
    settle(t);
    if (body.empty()) continue;
    t += line.line.wire_time(body.size());
    bus.receive(body, t);
    shadow.feed(body, t);
    settle(t);
  }
  // Let every frame complete and every reply go out.
  settle(t + std::chrono::milliseconds(100));
  settle(t + std::chrono::milliseconds(60000));
  check(owed.empty(), "the twin did not answer a frame it owes a reply");
}

// ---- harness 4 (extra): step tables from files --------------------------------

inline void steps_one(const uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const bool json = !text.empty() && text.front() == '{';
  auto parsed = json ? lec::parse_json(text) : lec::parse_csv(text);
  if (!parsed) {
    check(!parsed.error().empty(), "a step table refused without a message");
    return;
  }
  const lec::StepTable& table = *parsed;
  check(table.covered.any(), "a step table with no steps was accepted");
  for (unsigned n : table.covered_steps()) {
    const auto& s = table.steps[n];
    if (!s.is_blank())
      check(lec::validate(s).empty(), "a step table holds a step validate() refuses");
  }
  // What we write, we read back identically.
  for (auto format : {lec::TableFormat::Csv, lec::TableFormat::Json}) {
    const std::string out = lec::format_table(table, format);
    auto again = lec::parse_table(out, format);
    check(again.has_value(), "a step table we wrote does not parse");
    check(again->steps == table.steps && again->covered == table.covered &&
              again->controller_id == table.controller_id,
          "a step table does not survive a write and read");
  }
}

}  // namespace lec6::fuzz
