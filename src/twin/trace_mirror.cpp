#include "twin/trace_mirror.hpp"

#include <fmt/format.h>

#include "lec6/lec/explain.hpp"

namespace lec6::twin {

TraceMirror::TraceMirror(Duration silent_interval, modbus::FrameEnd end, TimePoint origin,
                         std::function<void(const std::string&)> sink)
    : framer_(silent_interval, end), origin_(origin), sink_(std::move(sink)) {}

void TraceMirror::feed(std::span<const uint8_t> bytes, TimePoint t) {
  framer_.feed(bytes, t);
  poll(t);
}

void TraceMirror::poll(TimePoint t) {
  while (auto f = framer_.poll(t)) {
    std::string meaning;
    if (auto q = modbus::decode_request(f->bytes)) {
      meaning = lec::explain_request(*q);
      last_request_[q->id] = *q;
    } else {
      meaning = lec::explain_bytes(f->bytes, lec::FrameRole::Request);
    }
    sink_(fmt::format("{:12.3f} ms  <- {}  | {}", ms_since_start(f->end_of_query),
                      modbus::to_hex(f->bytes), meaning));
  }
}

void TraceMirror::reply(const modbus::Bytes& bytes, TimePoint t, bool delivered) {
  std::string meaning;
  if (auto r = modbus::decode_response(bytes)) {
    auto q = last_request_.find(r->id);
    meaning = lec::explain_response(*r, q == last_request_.end() ? nullptr : &q->second);
  } else {
    meaning = lec::explain_bytes(bytes, lec::FrameRole::Reply);
  }
  sink_(fmt::format("{:12.3f} ms  -> {}  | {}{}", ms_since_start(t), modbus::to_hex(bytes), meaning,
                    delivered ? "" : "  (not delivered: no receiver)"));
}

}  // namespace lec6::twin
