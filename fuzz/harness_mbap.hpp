#pragma once
// The mbap harness: whatever a client may send to `lec serve`'s Modbus TCP
// port, through the MBAP framer and the gateway's rules (gateway.hpp), and
// the replies the daemon would build. Header-only like harness.hpp, so the
// libFuzzer program (fuzz/fuzz_mbap.cpp) and the ordinary regression test
// (tests/serve/modbus_tcp/mbap_fuzz_test.cpp) run the same checks.
//
// Input: [ctl][bytes a client sent]
//   ctl bit 0: the line allows broadcasts; bit 1: a read-only listener;
//   ctl seeds the random chunk sizes of the second reading.
//
// Properties:
//   - the same ADUs, and the same verdict on the stream (still open or
//     broken), however the bytes are cut: all at once, or in random chunks;
//   - the framer never holds more bytes than it was fed; a broken stream
//     says why;
//   - each ADU is either answered at once with a gateway or controller
//     exception code, or becomes a request for a configured unit (or a
//     broadcast write when allowed) that the codec encodes and decodes back
//     to itself, with the memory map's rules satisfied; never a write on a
//     read-only listener;
//   - every reply the daemon can give to it (answered, no answer, offline,
//     line down, shutting down) fits in one MBAP frame.

#include <vector>

#include "harness.hpp"
#include "lec6/modbus/mbap.hpp"
#include "modbus_tcp/gateway.hpp"
#include "seeds.hpp"

namespace lec6::fuzz {

namespace mbap_detail {

struct Outcome {
  std::vector<modbus::MbapAdu> adus;
  bool broken = false;
};

inline Outcome frame(std::span<const uint8_t> bytes, Rng* chunks) {
  modbus::MbapFramer f;
  Outcome o;
  std::size_t fed = 0;
  while (fed < bytes.size()) {
    const std::size_t n = chunks ? 1 + chunks->below(std::min<std::size_t>(bytes.size() - fed, 64))
                                 : bytes.size() - fed;
    f.feed(bytes.subspan(fed, n));
    fed += n;
    check(f.buffered() <= fed, "the MBAP framer holds more bytes than it was fed");
    while (auto adu = f.next()) o.adus.push_back(std::move(*adu));
    if (f.status() == modbus::MbapFramer::Status::Broken) {
      check(!f.error().empty(), "a broken MBAP stream without a reason");
      o.broken = true;
      break;
    }
  }
  return o;
}

inline void check_replies(const modbus::RequestFrame& frame) {
  using serve::Failure;
  for (Failure f : {Failure::None, Failure::NoAnswer, Failure::Offline, Failure::LineDown,
                    Failure::ShuttingDown}) {
    serve::JobResult r;
    r.failure = f;
    if (f == Failure::None) {
      r.reply = modbus::ResponseFrame{
          frame.id, modbus::ExceptionResponse{modbus::function_of(frame.pdu),
                                              static_cast<uint8_t>(modbus::function_of(frame.pdu)),
                                              modbus::ExceptionCode::IllegalAddress}};
    }
    const auto reply = serve::tcp_reply(frame, r);
    check(reply.has_value(), "a failed job without a reply for the master");
    const auto pdu = modbus::encode_response_pdu(*reply);
    check(pdu.size() <= modbus::kMaxMbapPdu, "a reply longer than one MBAP frame");
  }
}

inline void check_decision(const serve::GatewayPolicy& policy, const modbus::MbapAdu& adu) {
  const auto d = serve::decide(policy, adu.header.unit, adu.pdu);
  if (const auto* local = std::get_if<serve::LocalAnswer>(&d)) {
    const auto* ex = std::get_if<modbus::ExceptionResponse>(&local->pdu);
    check(ex != nullptr, "a local answer that is not an exception");
    const auto code = static_cast<uint8_t>(ex->code);
    check(code == 0x01 || code == 0x02 || code == 0x03 || code == 0x0A,
          "a local answer with an unexpected exception code");
    return;
  }
  const auto& line = std::get<serve::LineRequest>(d);
  const uint8_t id = line.frame.id;
  check(id == adu.header.unit, "a request sent to another unit than asked");
  check(policy.units.contains(id) || (id == 0 && policy.allow_broadcast),
        "a request for a unit the line does not have");
  const bool write = modbus::is_write(line.frame.pdu);
  check(!(write && policy.read_only), "a write let through a read-only listener");
  check(!(id == 0 && !write), "a read sent as a broadcast");
  check(!lec::check_request(line.frame.pdu, true).has_value(),
        "a request the memory map refuses was sent to the line");
  const auto encoded = modbus::encode_request_pdu(line.frame.pdu);
  check(encoded.has_value(), "a request the codec cannot encode was sent to the line");
  const auto back = modbus::decode_request_pdu(*encoded);
  check(back.has_value() && *back == line.frame.pdu, "a request that does not survive encoding");
  check_replies(line.frame);
}

}  // namespace mbap_detail

inline void mbap_one(const uint8_t* data, std::size_t size) {
  if (size == 0) return;
  const uint8_t ctl = data[0];
  const std::span<const uint8_t> bytes(data + 1, size - 1);
  serve::GatewayPolicy policy;
  policy.units = {1, 2, 3, 255};
  policy.allow_broadcast = ctl & 1;
  policy.read_only = ctl & 2;
  policy.cache_max_age = std::chrono::milliseconds(200);
  const auto whole = mbap_detail::frame(bytes, nullptr);
  Rng rng(ctl * 0x9E37ULL + size);
  const auto chunked = mbap_detail::frame(bytes, &rng);
  check(whole.broken == chunked.broken && whole.adus == chunked.adus,
        "the ADUs depend on how the bytes were cut");
  for (const auto& adu : whole.adus) mbap_detail::check_decision(policy, adu);
}

// Seeds: every golden query as a Modbus TCP request, singly and pipelined,
// for configured units and others, and a few broken streams.
inline std::vector<Seed> mbap_seeds(const std::string& tsv) {
  std::vector<Seed> seeds;
  std::vector<modbus::Bytes> adus;
  uint16_t tid = 1;
  for (const auto& q : detail::queries(parse_golden(tsv))) {
    const std::span<const uint8_t> pdu(q.data() + 1, q.size() - 3);  // without ID and CRC
    adus.push_back(modbus::encode_mbap(tid++, q[0], pdu));
  }
  for (std::size_t i = 0; i < adus.size(); ++i) {
    for (uint8_t ctl : {uint8_t{0}, uint8_t{3}}) {
      modbus::Bytes b;
      b.reserve(1 + adus[i].size());
      b.push_back(ctl);
      b.insert(b.end(), adus[i].begin(), adus[i].end());
      seeds.emplace_back("adu-" + std::to_string(i) + "-" + std::to_string(ctl), b);
    }
  }
  modbus::Bytes all;
  all.push_back(1);
  for (const auto& a : adus) all.insert(all.end(), a.begin(), a.end());
  seeds.emplace_back("pipelined", all);
  seeds.emplace_back("protocol-7", modbus::Bytes{0, 0, 1, 0, 7, 0, 6, 1, 3, 0x90, 0, 0, 7});
  seeds.emplace_back("length-65535", modbus::Bytes{0, 0, 1, 0, 0, 0xFF, 0xFF, 1});
  seeds.emplace_back("rtu-frame", modbus::Bytes{0, 1, 3, 0x90, 0, 0, 7, 0xE8, 0xC8});
  return seeds;
}

}  // namespace lec6::fuzz
