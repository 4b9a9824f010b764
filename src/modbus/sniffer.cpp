// The listen-only line observer (see the header for the rules).

#include "lec6/modbus/sniffer.hpp"

#include <algorithm>
#include <array>

#include "lec6/modbus/crc.hpp"
#include "lec6/modbus/length.hpp"

namespace lec6::modbus {
namespace {

constexpr uint8_t kChunkFirst = 1;
constexpr uint8_t kChunkLast = 2;
// The share of frames arriving in a chunk that other bytes began (a moving
// average over about fifty frames): above 10 % the adapter is taken to
// deliver in lumps, until it falls below 2 % again. An adapter without a
// latency timer merges frames only when the reader falls behind (rarely);
// a 16 ms timer merges a third of them or more.
constexpr double kMergedWeight = 0.02;
constexpr double kLumpyOn = 0.10;
constexpr double kLumpyOff = 0.02;

uint16_t word_at(std::span<const uint8_t> b, std::size_t i) {
  return static_cast<uint16_t>(b[i] << 8 | b[i + 1]);
}

// The normal reply's length for a query (a CRC-confirmed request frame).
std::size_t reply_length_for(std::span<const uint8_t> q) {
  switch (q[1]) {
    case 0x01:
    case 0x02:
      return 5 + (word_at(q, 4) + 7u) / 8u;
    case 0x03:
    case 0x04:
      return 5 + 2u * word_at(q, 4);
    case 0x07:
      return 5;
    case 0x16:
      return 10;
    case 0x17:  // read/write multiple registers: the read count (issue 33)
      return 5 + 2u * word_at(q, 4);
    case 0x0C:
    case 0x11:
      return 0;  // variable: any length the reply's byte count gives
    default:
      return 8;
  }
}

// Standard Modbus functions the LEC does not have (length.hpp sizes only the
// LEC's): a master may still send them, and the controller answers exception 01.
FrameLength other_request_length(std::span<const uint8_t> head) {
  switch (head[1]) {
    case 0x04:  // read input registers
    case 0x06:  // write single register
      return FrameLength::known(8);
    case 0x07:  // read exception status
    case 0x0B:  // get comm event counter
    case 0x0C:  // get comm event log
    case 0x11:  // report server ID
      return FrameLength::known(4);
    case 0x16:  // mask write register
      return FrameLength::known(10);
    case 0x17:  // read/write multiple registers
      if (head.size() < 11) return FrameLength::need_more();
      return FrameLength::known(13u + head[10]);
    default:
      return FrameLength::unknown();
  }
}

FrameLength other_response_length(std::span<const uint8_t> head) {
  switch (head[1]) {
    case 0x06:
    case 0x0B:
      return FrameLength::known(8);
    case 0x07:
      return FrameLength::known(5);
    case 0x16:
      return FrameLength::known(10);
    case 0x04:
    case 0x0C:
    case 0x11:
    case 0x17:
      if (head.size() < 3) return FrameLength::need_more();
      return FrameLength::known(5u + head[2]);
    default:
      return FrameLength::unknown();
  }
}

}  // namespace

Duration response_percentile(const SniffIdStats& s, double p) {
  if (s.response_us.empty()) return Duration::zero();
  std::vector<uint32_t> v = s.response_us;
  const auto k =
      static_cast<std::size_t>(std::clamp(p, 0.0, 1.0) * static_cast<double>(v.size() - 1) + 0.5);
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return std::chrono::microseconds(v[k]);
}

Sniffer::Sniffer(const SnifferOptions& options) : options_(options) {}

namespace {

// One frame at the head of the bytes, its length from `own` (what LEC
// controllers speak) or else `other` (any Modbus function): confirmed by its
// CRC, or not yet complete, or no such frame.
template <typename Own, typename Other>
Sniffer::Reading read_frame(std::span<const uint8_t> head, std::size_t& length, Own own,
                            Other other) {
  FrameLength l = own(head);
  if (l.status == FrameLength::Status::Unknown) l = other(head);
  if (l.status == FrameLength::Status::NeedMore) return Sniffer::Reading::Incomplete;
  if (l.status == FrameLength::Status::Unknown) return Sniffer::Reading::Failed;
  length = l.bytes;
  if (head.size() < length) return Sniffer::Reading::Incomplete;
  return crc_ok(head.first(length)) ? Sniffer::Reading::Confirmed : Sniffer::Reading::BadCrc;
}

}  // namespace

Sniffer::Reading Sniffer::try_query(std::span<const uint8_t> head, std::size_t& length) const {
  return read_frame(head, length, request_length, other_request_length);
}

Sniffer::Reading Sniffer::try_reply(std::span<const uint8_t> head, std::size_t& length) const {
  return read_frame(head, length, response_length, other_response_length);
}

// The reply the waiting query asks for: its ID, its function (or the
// exception to it), and for a normal reply its length.
bool Sniffer::matches_pending(std::span<const uint8_t> frame) const {
  if (!pending_ || frame.size() < 2 || frame[0] != pending_->query[0]) return false;
  const uint8_t fc = pending_->query[1];
  if (frame[1] == (fc | kExceptionFlag)) return true;
  return frame[1] == fc && (pending_->reply_length == 0 || frame.size() == pending_->reply_length);
}

// FC05/FC06/FC08 replies equal their queries, so a master's resend of such a
// query after no answer looks like the first one's reply. A candidate: a
// frame equal to the waiting query, delivered in chunks of its own, that
// began after the controller's response time (Tx + tolerance); judge_resend()
// then decides by timing and by what follows (untimed frames keep the reply
// reading).
bool Sniffer::resent_query(std::size_t length) const {
  if (!pending_ || !pending_->timed || !timed_frame(head_, length)) return false;
  if (!std::equal(pending_->query.begin(), pending_->query.end(), buf_.begin() + head_,
                  buf_.begin() + static_cast<std::ptrdiff_t>(head_ + length)) ||
      pending_->query.size() != length)
    return false;
  const TimePoint start = times_[head_ + length - 1] - options_.timing.wire_time(length);
  return start > pending_->end + options_.timing.response_time(length) + options_.tolerance;
}

// A candidate (resent_query) is the query sent again when:
//  - it began at least twice the reply window (Tx + tolerance) after the
//    query, and later than 1.5 times the slowest reply this ID gave to a
//    query it did not echo: a LEC answers within Tx, a master resends after
//    its own timeout; a device seen to be slow keeps its late echoes; or
//  - its own reply follows at once: a frame equal to it or the exception to
//    it, beginning within the reply window after it and sooner than it came
//    after the query (a reply is quicker than a master's retry).
// Otherwise it is the late reply: a master that repeats the same write every
// cycle is answered late, not resending (issue 33's review). Undecided while
// the bytes after it could still become its reply and no silence settled them.
Sniffer::Resend Sniffer::judge_resend(std::span<const uint8_t> head, std::size_t length,
                                      bool settle) const {
  const Duration window = options_.timing.response_time(length) + options_.tolerance;
  const TimePoint end = times_[head_ + length - 1];
  const Duration gap = end - options_.timing.wire_time(length) - pending_->end;
  Duration slowest{};
  if (const auto it = longest_reply_.find(head[0]); it != longest_reply_.end())
    slowest = it->second;
  if (gap >= 2 * window && gap > slowest * 3 / 2) return Resend::Yes;
  // Its own reply next? An echo of `length` bytes or a 5-byte exception.
  const auto rest = head.subspan(length);
  std::size_t reply = 0;
  bool may_become = false;
  const std::array<uint8_t, 2> exception_head{head[0], static_cast<uint8_t>(head[1] | 0x80)};
  if (rest.size() >= kExceptionLength && rest[0] == exception_head[0] &&
      rest[1] == exception_head[1] && crc_ok(rest.first(kExceptionLength))) {
    reply = kExceptionLength;
  } else if (rest.size() >= length &&
             std::equal(head.begin(), head.begin() + length, rest.begin())) {
    reply = length;
  } else {
    const std::size_t n = rest.size();
    may_become =
        std::equal(rest.begin(), rest.end(), head.begin(), head.begin() + std::min(n, length)) &&
        n < length;
    may_become = may_become || (n < kExceptionLength &&
                                std::equal(rest.begin(), rest.begin() + std::min<std::size_t>(n, 2),
                                           exception_head.begin()));
  }
  if (reply == 0) return may_become && !settle ? Resend::Undecided : Resend::No;
  // A follower delivered with other bytes has no time of its own: the reply
  // reading stays (found in review: one lumped read turned a late echo into
  // a query, and the misreading ran on).
  if (!timed_frame(head_ + length, reply)) return Resend::No;
  const Duration after =
      times_[head_ + length + reply - 1] - options_.timing.wire_time(reply) - end;
  return after > window || after >= gap ? Resend::No : Resend::Yes;
}

bool Sniffer::timed_frame(std::size_t first, std::size_t length) const {
  return options_.check_timing && !lumpy_now_ && (marks_[first] & kChunkFirst) &&
         (marks_[first + length - 1] & kChunkLast);
}

void Sniffer::note_frame_boundary(std::size_t first) {
  const double merged = (marks_[first] & kChunkFirst) ? 0.0 : 1.0;
  merged_ratio_ = (1 - kMergedWeight) * merged_ratio_ + kMergedWeight * merged;
  lumpy_now_ = merged_ratio_ > (lumpy_now_ ? kLumpyOff : kLumpyOn);
  if (lumpy_now_) stats_.lumpy = true;
}

SniffEvent Sniffer::make_event(SniffKind kind, std::size_t first, std::size_t length) const {
  SniffEvent e;
  e.kind = kind;
  e.bytes.assign(buf_.begin() + static_cast<std::ptrdiff_t>(first),
                 buf_.begin() + static_cast<std::ptrdiff_t>(first + length));
  e.first_byte = times_[first];
  e.last_byte = times_[first + length - 1];
  return e;
}

void Sniffer::flush_noise() {
  if (noise_length_ == 0) return;
  SniffEvent e = make_event(SniffKind::Noise, head_ - noise_length_, noise_length_);
  if (noise_bad_crc_) e.flags |= kSniffBadCrc;
  ++stats_.noise_bursts;
  stats_.noise_bytes += noise_length_;
  noise_length_ = 0;
  noise_bad_crc_ = false;
  events_.push_back(std::move(e));
}

void Sniffer::emit_no_reply() {
  SniffEvent e;
  e.kind = SniffKind::NoReply;
  e.bytes = pending_->query;
  e.first_byte = e.last_byte = pending_->end;
  e.query_number = pending_->number;
  ++stats_.ids[pending_->query[0]].timeouts;
  pending_.reset();
  events_.push_back(std::move(e));
}

// A frame of a function code no table sizes (see the header): its length
// from its CRC, checked where the frame must end: its chunk's end (or a
// settled end), a frame a table confirms, or another unknown frame that ends
// so (a device answering an unknown function, delivered with its query in one
// lump by a USB adapter: the query's CRC ends neither the chunk nor a known
// frame; its answer's does).
std::optional<std::size_t> Sniffer::unknown_frame(std::span<const uint8_t> head, bool settle,
                                                  std::size_t offset, bool followed) const {
  constexpr std::size_t kShortest = 4, kLongest = 256;
  if (head.size() < kShortest || head[0] > 247 || head[1] == 0 || (head[1] & kExceptionFlag))
    return std::nullopt;
  uint16_t crc = crc16(head.first(kShortest - 2));
  for (std::size_t length = kShortest; length <= std::min(head.size(), kLongest); ++length) {
    if (length > kShortest) crc = crc16_update(crc, head.subspan(length - 3, 1));
    if (head[length - 2] != (crc & 0xFFU) || head[length - 1] != (crc >> 8)) continue;
    if ((marks_[head_ + offset + length - 1] & kChunkLast) || (settle && length == head.size()))
      return length;
    std::size_t next = 0;
    const auto rest = head.subspan(length);
    if (try_query(rest, next) == Reading::Confirmed || try_reply(rest, next) == Reading::Confirmed)
      return length;
    if (followed && unknown_frame(rest, settle, offset + length, false)) return length;
  }
  return std::nullopt;
}

void Sniffer::emit_query(std::size_t length, uint32_t flags) {
  flush_noise();
  note_frame_boundary(head_);
  SniffEvent e = make_event(SniffKind::Query, head_, length);
  e.flags |= flags;
  if (flags & kSniffUnknownFunction) ++stats_.unknown_functions;
  const bool timed = timed_frame(head_, length);
  const TimePoint start = e.last_byte - options_.timing.wire_time(length);
  if (pending_) {
    // Within the controller's response time of the waiting query: no single
    // master would send now.
    if (start < pending_->end + options_.timing.response_time(std::max<std::size_t>(
                                    pending_->reply_length, kExceptionLength))) {
      e.flags |= kSniffSecondMaster;
      ++stats_.second_master;
    }
    emit_no_reply();
  }
  e.limit = options_.timing.silent_interval();
  if (timed && previous_timed_ && previous_end_) {
    e.silence = start - *previous_end_;
    // A quarter of Ts is left for the adapter's delivery jitter.
    if (*e.silence < e.limit * 3 / 4) {
      e.flags |= kSniffShortSilence;
      ++stats_.short_silences;
    }
  } else {
    ++stats_.untimed;
  }
  e.query_number = ++queries_;
  ++stats_.frames;
  const uint8_t id = e.bytes[0];
  ++stats_.ids[id].queries;
  if (id == kBroadcastId) {
    e.flags |= kSniffBroadcast;
  } else {
    // A function no table sizes: its normal reply may be any length.
    pending_ = Pending{e.bytes, e.query_number, e.last_byte, timed,
                       (flags & kSniffUnknownFunction) ? 0 : reply_length_for(e.bytes)};
  }
  previous_end_ = e.last_byte;
  previous_timed_ = timed;
  head_ += length;
  events_.push_back(std::move(e));
}

void Sniffer::emit_reply(std::size_t length, bool paired, uint32_t flags) {
  flush_noise();
  note_frame_boundary(head_);
  SniffEvent e = make_event(SniffKind::Reply, head_, length);
  e.flags |= flags;
  if (flags & kSniffUnknownFunction) ++stats_.unknown_functions;
  const bool timed = timed_frame(head_, length);
  const uint8_t id = e.bytes[0];
  SniffIdStats& s = stats_.ids[id];
  ++stats_.frames;
  if (paired) {
    e.query = std::move(pending_->query);
    e.query_number = pending_->number;
    e.limit = options_.timing.response_time(length);
    if (timed && pending_->timed) {
      e.response = e.last_byte - pending_->end;
      s.response_us.push_back(static_cast<uint32_t>(std::clamp<int64_t>(
          std::chrono::duration_cast<std::chrono::microseconds>(*e.response).count(), 0,
          UINT32_MAX)));
      if (!std::equal(e.bytes.begin(), e.bytes.end(), e.query.begin(), e.query.end())) {
        Duration& slowest = longest_reply_[id];
        slowest = std::max(slowest, *e.response);
      }
      if (*e.response > e.limit + options_.tolerance) {
        e.flags |= kSniffLate;
        ++s.late;
      }
    } else {
      ++stats_.untimed;
    }
    ++s.exchanges;
    if (e.bytes[1] & kExceptionFlag) ++s.exceptions;
    pending_.reset();
  } else {
    e.flags |= kSniffUnsolicited;
    ++s.unsolicited;
  }
  previous_end_ = e.last_byte;
  previous_timed_ = timed;
  head_ += length;
  events_.push_back(std::move(e));
}

void Sniffer::scan(bool settle) {
  while (unresolved()) {
    const std::span<const uint8_t> head(buf_.data() + head_, buf_.size() - head_);
    std::size_t qlen = 0, rlen = 0;
    const Reading q = try_query(head, qlen);
    const Reading r = try_reply(head, rlen);
    // Could these bytes still become the awaited reply?
    const bool may_be_reply =
        pending_ && head[0] == pending_->query[0] &&
        (head.size() < 2 || (head[1] & ~kExceptionFlag) == pending_->query[1]);
    if (pending_) {
      if (r == Reading::Confirmed && matches_pending(head.first(rlen))) {
        if (resent_query(rlen)) {
          // Late and equal to the query: the query again, or its late reply
          // (judge_resend; decided when the next bytes are in, or at the
          // silence that settles them: issue 33).
          const Resend resend = judge_resend(head, rlen, settle);
          if (resend == Resend::Undecided) return;
          if (resend == Resend::Yes) {
            emit_query(rlen);
            continue;
          }
        }
        emit_reply(rlen, true);
        continue;
      }
      if (r == Reading::Incomplete && may_be_reply && !settle) return;
      if (q == Reading::Confirmed) {
        emit_query(qlen);
        continue;
      }
      if (q == Reading::Incomplete && !settle) return;
      if (r == Reading::Confirmed) {
        emit_reply(rlen, false);
        continue;
      }
    } else {
      if (q == Reading::Confirmed) {
        emit_query(qlen);
        continue;
      }
      if (q == Reading::Incomplete && !settle) return;
      if (r == Reading::Confirmed) {
        emit_reply(rlen, false);
        continue;
      }
      if (r == Reading::Incomplete && !settle) return;
    }
    // No table knows this function code: a frame of unknown kind, if its CRC says so.
    if (q == Reading::Failed && r == Reading::Failed) {
      if (const auto length = unknown_frame(head, settle)) {
        if (pending_ && head[0] == pending_->query[0] && head[1] == pending_->query[1]) {
          emit_reply(*length, true, kSniffUnknownFunction);
        } else {
          emit_query(*length, kSniffUnknownFunction);
        }
        continue;
      }
    }
    // No reading confirms a frame here: this byte is noise.
    if (noise_length_ == 0) {
      // Where a frame should have begun: a frame of the right shape whose
      // CRC failed is a CRC error of that ID.
      const bool bad_reply = r == Reading::BadCrc && may_be_reply;
      const bool bad_query = !pending_ && q == Reading::BadCrc && stats_.ids.count(head[0]) > 0;
      if (bad_reply || bad_query) {
        noise_bad_crc_ = true;
        ++stats_.ids[head[0]].crc_errors;
      }
    }
    ++noise_length_;
    ++head_;
  }
  if (settle) flush_noise();
}

void Sniffer::compact() {
  const std::size_t keep_from = head_ - noise_length_;
  if (keep_from < 4096) return;
  const auto n = static_cast<std::ptrdiff_t>(keep_from);
  buf_.erase(buf_.begin(), buf_.begin() + n);
  times_.erase(times_.begin(), times_.begin() + n);
  marks_.erase(marks_.begin(), marks_.begin() + n);
  head_ -= keep_from;
}

void Sniffer::feed(std::span<const uint8_t> bytes, TimePoint arrival) {
  advance(arrival);
  if (bytes.empty()) return;
  const std::size_t first = buf_.size();
  buf_.insert(buf_.end(), bytes.begin(), bytes.end());
  times_.resize(buf_.size(), arrival);
  marks_.resize(buf_.size(), 0);
  marks_[first] |= kChunkFirst;
  marks_.back() |= kChunkLast;
  last_arrival_ = arrival;
  have_arrival_ = true;
  scan(false);
  compact();
}

void Sniffer::advance(TimePoint now) {
  if (unresolved() && have_arrival_ && now - last_arrival_ >= options_.idle_gap) {
    scan(true);
    compact();
  }
  if (pending_ && !unresolved() && now >= pending_->end + options_.reply_wait) emit_no_reply();
}

void Sniffer::finish(TimePoint now) {
  advance(now);
  scan(true);
  if (pending_) emit_no_reply();
  compact();
}

std::vector<SniffEvent> Sniffer::take() {
  std::vector<SniffEvent> out(std::make_move_iterator(events_.begin()),
                              std::make_move_iterator(events_.end()));
  events_.clear();
  return out;
}

std::optional<TimePoint> Sniffer::deadline() const {
  // Only what advance() acts on: a deadline it would not act on made a
  // caller's loop spin (found by fuzz_sniff: a query's reply wait ran out
  // while bytes waited for the idle gap; lec sniff's read loop then woke
  // without pause until the gap ended). Buffered bytes settle after the idle
  // gap; only then can a waiting query's reply wait end.
  if (unresolved()) {
    if (have_arrival_) return last_arrival_ + options_.idle_gap;
    return std::nullopt;
  }
  if (pending_) return pending_->end + options_.reply_wait;
  return std::nullopt;
}

}  // namespace lec6::modbus
