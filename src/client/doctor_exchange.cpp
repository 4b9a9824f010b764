// lec doctor: what one exchange brought back (echo, reply, noise), and
// another master's queries among bytes heard while we were silent.

#include <algorithm>

#include "lec6/client/doctor.hpp"
#include "lec6/modbus/crc.hpp"
#include "lec6/modbus/length.hpp"
#include "lec6/modbus/pdu.hpp"

namespace lec6::client::doctor {

ExchangeResult classify_exchange(std::span<const uint8_t> query, std::span<const uint8_t> heard) {
  ExchangeResult r;
  std::size_t start = 0;
  if (!query.empty() && heard.size() >= query.size() &&
      std::equal(query.begin(), query.end(), heard.begin())) {
    r.echo = true;
    start = query.size();
  }
  if (query.size() < 2) {
    r.noise_bytes = heard.size() - start;
    r.kind = r.noise_bytes ? ReplyKind::Garbage : ReplyKind::None;
    return r;
  }
  const uint8_t id = query[0];
  const uint8_t fc = query[1];
  for (std::size_t i = start; i + 1 < heard.size(); ++i) {
    if (heard[i] != id || (heard[i + 1] & 0x7F) != fc) continue;
    const auto tail = heard.subspan(i);
    const auto len = modbus::response_length(tail);
    r.reply_offset = i;
    if (len.status != modbus::FrameLength::Status::Known || len.bytes > tail.size()) {
      r.kind = ReplyKind::Framing;  // ended early, or cannot be sized
      r.reply_bytes = tail.size();
      r.noise_bytes = i - start;
      return r;
    }
    r.reply_bytes = len.bytes;
    r.noise_bytes = heard.size() - start - len.bytes;
    if (!modbus::crc_ok(tail.first(len.bytes))) {
      r.kind = ReplyKind::Crc;
    } else {
      r.kind = (heard[i + 1] & modbus::kExceptionFlag) ? ReplyKind::Exception : ReplyKind::Good;
    }
    return r;
  }
  if (heard.size() > start + 1 && heard[start] == id) {
    // The ID asked, then garbage: a reply mangled after its first byte.
    r.kind = ReplyKind::Crc;
    r.reply_offset = start;
    r.reply_bytes = heard.size() - start;
    return r;
  }
  r.noise_bytes = heard.size() - start;
  r.kind = r.noise_bytes ? ReplyKind::Garbage : ReplyKind::None;
  return r;
}

std::vector<uint8_t> foreign_queries(std::span<const uint8_t> heard) {
  std::vector<uint8_t> ids;
  for (std::size_t i = 0; i + 4 <= heard.size();) {
    const auto tail = heard.subspan(i);
    const auto len = modbus::request_length(tail);
    if (heard[i] != modbus::kBroadcastId && len.status == modbus::FrameLength::Status::Known &&
        len.bytes >= 4 && len.bytes <= tail.size() && modbus::crc_ok(tail.first(len.bytes))) {
      ids.push_back(heard[i]);
      i += len.bytes;
      // The controller's reply to it follows: skip a sound reply too.
      const auto rest = heard.subspan(i);
      const auto rlen = modbus::response_length(rest);
      if (rlen.status == modbus::FrameLength::Status::Known && rlen.bytes >= 4 &&
          rlen.bytes <= rest.size() && rest[0] == ids.back() &&
          modbus::crc_ok(rest.first(rlen.bytes)))
        i += rlen.bytes;
      continue;
    }
    ++i;
  }
  return ids;
}

}  // namespace lec6::client::doctor
