// The twin on the line (timing, exceptions, faults): rows R-TIME-* and R-EXC-* of
// docs/twin-fidelity.md name this file.
#include "lec6/sim/bus.hpp"
#include "lec6/error.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "lec6/modbus/crc.hpp"

namespace lec6::sim {

namespace {
// The noise generator's seed differs from the fault generator's.
constexpr uint64_t kNoiseSalt = 0x6E6F697365ULL;  // "noise"
}  // namespace

Bus::Bus(const LineConfig& line, const FaultConfig& faults)
    : line_(line),
      faults_(faults),
      rng_(faults.seed),
      framer_(line.line.silent_interval(), line.timing == Timing::Fast
                                               ? modbus::FrameEnd::LengthOrSilence
                                               : modbus::FrameEnd::Silence),
      noise_rng_(faults.seed ^ kNoiseSalt) {}

void Bus::set_faults(const FaultConfig& f) {
  faults_ = f;
  rng_.seed(f.seed);
  noise_rng_.seed(f.seed ^ kNoiseSalt);
  next_noise_.reset();
}

Controller& Bus::add(uint8_t id, const ActuatorConfig& config, TimePoint power_on,
                     const std::optional<Eeprom>& eeprom) {
  if (id == modbus::kBroadcastId) throw InvalidArgument("controller ID 0 is the broadcast address");
  if (controllers_.count(id)) {
    throw InvalidArgument("controller ID " + std::to_string(id) + " is already on the bus");
  }
  auto c = std::make_unique<Controller>(config, power_on, eeprom);
  Controller& ref = *c;
  controllers_.emplace(id, std::move(c));
  return ref;
}

Controller* Bus::find(uint8_t id) {
  auto it = controllers_.find(id);
  return it == controllers_.end() ? nullptr : it->second.get();
}

const Controller* Bus::find(uint8_t id) const {
  auto it = controllers_.find(id);
  return it == controllers_.end() ? nullptr : it->second.get();
}

std::map<uint8_t, Eeprom> Bus::eeproms() const {
  std::map<uint8_t, Eeprom> out;
  for (const auto& [id, c] : controllers_) out.emplace(id, c->eeprom());
  return out;
}

uint64_t Bus::eeprom_generation() const {
  uint64_t sum = 0;
  for (const auto& [id, c] : controllers_) sum += c->eeprom_generation();
  return sum;
}

void Bus::set_cut_off(uint8_t id, bool cut_off) {
  if (cut_off)
    cut_off_.insert(id);
  else
    cut_off_.erase(id);
}

Controller* Bus::listening(uint8_t id) {
  return cut_off_.count(id) ? nullptr : find(id);
}

std::vector<uint8_t> Bus::ids() const {
  std::vector<uint8_t> out;
  for (const auto& [id, c] : controllers_) out.push_back(id);
  return out;
}

void Bus::receive(std::span<const uint8_t> bytes, TimePoint arrival) {
  if (noisy() && !bytes.empty()) {
    // Byte by byte at the instants they arrived: a noise byte just before
    // the query joins its frame when it is within Ts of the *first* byte.
    // While the master transmits there is no idle-line noise.
    const Duration c = line_.line.char_time();
    const TimePoint first = arrival - c * static_cast<int64_t>(bytes.size() - 1);
    advance(first - c);
    skip_noise(arrival);
    for (std::size_t i = 0; i < bytes.size(); ++i)
      framer_.feed(bytes.subspan(i, 1), first + c * static_cast<int64_t>(i));
  } else {
    framer_.feed(bytes, arrival);
  }
  advance(arrival);
}

void Bus::advance(TimePoint now) {
  if (noisy()) {
    // In time order: a frame that completes before a noise byte acts first,
    // so its reply keeps that noise off the line.
    for (;;) {
      const auto due = framer_.deadline();
      const TimePoint step = due && *due < now ? *due : now;
      make_noise(step);
      while (auto frame = framer_.poll(step)) act_on(*frame);
      if (step >= now) break;
    }
  } else {
    while (auto frame = framer_.poll(now)) act_on(*frame);
  }
  for (auto& [id, c] : controllers_) c->advance(now);
}

// ---- idle-line noise -------------------------------------------------------------

void Bus::draw_noise_after(TimePoint t) {
  const double gap_s = std::exponential_distribution<double>(faults_.noise_rate)(noise_rng_);
  const Duration gap(static_cast<int64_t>(std::min(gap_s, 3600.0) * 1e9));
  next_noise_ = t + gap + line_.line.char_time();
}

void Bus::make_noise(TimePoint until) {
  if (!next_noise_) draw_noise_after(until);
  while (*next_noise_ <= until) {
    const TimePoint end = *next_noise_;
    const TimePoint start = end - line_.line.char_time();
    draw_noise_after(end);
    // Idle-line noise only: not while one of our replies is on the wire.
    const bool on_reply = std::any_of(pending_.begin(), pending_.end(), [&](const Reply& r) {
      return !r.noise && r.start < end && start < r.end;
    });
    if (on_reply || (start < line_free_ && last_reply_start_ < end)) continue;
    const uint8_t b =
        static_cast<uint8_t>(std::uniform_int_distribution<unsigned>(0, 255)(noise_rng_));
    ++stats_.noise_bytes;
    framer_.feed(std::span<const uint8_t>(&b, 1), end);  // the controllers hear it too
    queue(Reply{modbus::kBroadcastId, start, end, {b}, true});
  }
}

void Bus::skip_noise(TimePoint until) {
  if (!next_noise_) draw_noise_after(until);
  while (*next_noise_ <= until) draw_noise_after(*next_noise_);
}

void Bus::act_on(const modbus::DeviceFramer::Frame& frame) {
  ++stats_.frames;
  const bool real = line_.timing == Timing::Real;
  const Duration ts = line_.line.silent_interval();
  // The controller knows a frame is complete Ts after its last byte (real);
  // in fast timing the moment its expected length is in.
  const TimePoint act_at = frame.end_of_query + (real ? ts : Duration::zero());
  // The reply's last byte leaves at end of query + Ts + T0 + Td + wire (digest §1).
  const TimePoint reply_start =
      real ? frame.end_of_query + ts + modbus::LineTiming::kProcessing + line_.line.delay_td
           : act_at;

  if (frame.length > modbus::kMaxAdu) return answer_too_long(frame, reply_start);
  const modbus::Bytes& bytes = frame.bytes;
  if (bytes.size() < 4 || !modbus::crc_ok(bytes)) {
    ++stats_.bad_frames;  // garbled: no reply, no effect
    return;
  }
  const uint8_t id = bytes[0];
  const bool broadcast = id == modbus::kBroadcastId;
  Controller* target = broadcast ? nullptr : listening(id);
  if (!broadcast && !target) {
    ++stats_.other_ids;
    return;
  }
  auto decoded = modbus::decode_request(bytes);
  if (!decoded) {
    if (broadcast) return;
    const uint8_t fc = bytes[1];
    modbus::ExceptionCode code;
    switch (decoded.error().kind) {
      case modbus::ErrorKind::UnknownFunction:
        code = modbus::ExceptionCode::IllegalFunction;
        break;
      case modbus::ErrorKind::BadByteCount:
        code = modbus::ExceptionCode::IllegalAccessRange;
        break;
      default:
        ++stats_.bad_frames;  // a frame whose length does not fit its function: silence
        return;
    }
    target->advance(act_at);
    ++stats_.exceptions;
    modbus::Bytes out = modbus::encode_response(
        {id, modbus::ExceptionResponse{static_cast<modbus::FunctionCode>(fc), fc, code}});
    schedule(id, std::move(out), reply_start);
    return;
  }
  const modbus::Request& request = decoded->pdu;
  if (broadcast) {
    // FC05/0F/10 act on every controller with no reply; reads and echo are ignored.
    if (!modbus::is_write(request)) return;
    ++stats_.broadcasts;
    for (auto& [cid, c] : controllers_) {
      if (!cut_off_.count(cid)) (void)c->handle(request, act_at);
    }
    return;
  }
  modbus::Response reply = target->handle(request, act_at);
  if (std::holds_alternative<modbus::ExceptionResponse>(reply)) ++stats_.exceptions;
  schedule(id, modbus::encode_response({id, std::move(reply)}), reply_start);
}

// More than 256 data bytes (digest §3): a sound frame (its CRC over all of
// its bytes holds) to a controller here gets exception 03 — 01 first when the
// function is unknown, as the digest's order of checks says. A garbled one
// gets silence, as any bad frame; a broadcast is not executed.
void Bus::answer_too_long(const modbus::DeviceFramer::Frame& frame, TimePoint reply_start) {
  if (!frame.long_crc_ok) {
    ++stats_.bad_frames;
    return;
  }
  const uint8_t id = frame.bytes[0];
  const uint8_t fc = frame.bytes[1];
  if (id == modbus::kBroadcastId) return;
  Controller* target = listening(id);
  if (!target) {
    ++stats_.other_ids;
    return;
  }
  ++stats_.long_frames;
  ++stats_.exceptions;
  const auto code = modbus::is_known_function(fc) ? modbus::ExceptionCode::IllegalAccessRange
                                                  : modbus::ExceptionCode::IllegalFunction;
  schedule(id,
           modbus::encode_response(
               {id, modbus::ExceptionResponse{static_cast<modbus::FunctionCode>(fc), fc, code}}),
           reply_start);
}

void Bus::schedule(uint8_t id, modbus::Bytes bytes, TimePoint start) {
  ++stats_.replies;
  auto chance = [&](double p) {
    if (p <= 0.0) return false;
    if (p >= 1.0) return true;
    return std::bernoulli_distribution(p)(rng_);
  };
  if (std::find(faults_.duplicate_ids.begin(), faults_.duplicate_ids.end(), id) !=
          faults_.duplicate_ids.end() &&
      bytes.size() > 1 && chance(faults_.collision)) {
    // The twin's reply and its double's, a few bit times apart: the header
    // (ID, function, byte count: the same in both) survives, the data and
    // the CRC are a mix.
    for (std::size_t i = std::min<std::size_t>(3, bytes.size() - 2); i < bytes.size(); ++i) {
      if (std::bernoulli_distribution(0.5)(rng_))
        bytes[i] =
            static_cast<uint8_t>(bytes[i] ^ std::uniform_int_distribution<unsigned>(1, 255)(rng_));
    }
    if (modbus::crc_ok(bytes)) bytes.back() = static_cast<uint8_t>(bytes.back() ^ 0x01);
    ++stats_.collisions;
  }
  if (chance(faults_.drop)) {
    ++stats_.faults_dropped;
    return;
  }
  if (chance(faults_.corrupt) && !bytes.empty()) {
    const std::size_t i = std::uniform_int_distribution<std::size_t>(0, bytes.size() - 1)(rng_);
    bytes[i] =
        static_cast<uint8_t>(bytes[i] ^ std::uniform_int_distribution<unsigned>(1, 255)(rng_));
    ++stats_.faults_corrupted;
  }
  if (chance(faults_.garbage) && faults_.garbage_max_bytes > 0) {
    const unsigned n = std::uniform_int_distribution<unsigned>(1, faults_.garbage_max_bytes)(rng_);
    modbus::Bytes junk(n);
    for (auto& b : junk)
      b = static_cast<uint8_t>(std::uniform_int_distribution<unsigned>(0, 255)(rng_));
    bytes.insert(bytes.begin(), junk.begin(), junk.end());
    ++stats_.faults_garbage;
  }
  if (chance(faults_.delay)) {
    start += faults_.extra_delay;
    ++stats_.faults_delayed;
  }
  // Half duplex: one reply at a time on the line. Fast timing models no line
  // at all (digest §1: no artificial delay), so a reply takes no wire time.
  start = std::max(start, line_free_);
  const Duration wire =
      line_.timing == Timing::Fast ? Duration{0} : line_.line.wire_time(bytes.size());
  Reply r{id, start, start + wire, std::move(bytes)};
  last_reply_start_ = r.start;
  line_free_ = r.end;
  queue(std::move(r));
}

void Bus::queue(Reply r) {
  auto pos = std::upper_bound(pending_.begin(), pending_.end(), r.start,
                              [](TimePoint t, const Reply& x) { return t < x.start; });
  pending_.insert(pos, std::move(r));
}

std::vector<Reply> Bus::take_replies(TimePoint now) {
  std::vector<Reply> out;
  auto it = pending_.begin();
  while (it != pending_.end() && it->start <= now) ++it;
  std::move(pending_.begin(), it, std::back_inserter(out));
  pending_.erase(pending_.begin(), it);
  return out;
}

std::optional<TimePoint> Bus::next_deadline() const {
  std::optional<TimePoint> d = framer_.deadline();
  if (!pending_.empty() && (!d || pending_.front().start < *d)) d = pending_.front().start;
  if (noisy() && next_noise_ && (!d || *next_noise_ < *d)) d = next_noise_;
  return d;
}

std::optional<TimePoint> Bus::next_model_event() const {
  std::optional<TimePoint> d;
  for (const auto& [id, c] : controllers_) {
    if (auto e = c->next_event(); e && (!d || *e < *d)) d = e;
  }
  return d;
}

std::optional<Reply> transact(Bus& bus, std::span<const uint8_t> query, TimePoint start,
                              Duration timeout) {
  const TimePoint end_of_query = start + bus.line().line.wire_time(query.size());
  bus.receive(query, end_of_query);
  const TimePoint give_up = end_of_query + timeout;
  TimePoint now = end_of_query;
  for (;;) {
    bus.advance(now);
    auto rs = bus.take_replies(now);
    // Idle-line noise is not an answer (a master's framer drops it).
    if (auto it = std::find_if(rs.begin(), rs.end(), [](const Reply& x) { return !x.noise; });
        it != rs.end()) {
      Reply r = std::move(*it);
      bus.advance(r.end);
      return r;
    }
    const auto d = bus.next_deadline();
    if (!d || *d > give_up) {
      bus.advance(give_up);
      return std::nullopt;
    }
    now = std::max(now, *d);
  }
}

}  // namespace lec6::sim
