#include "lec6/twin/replay_run.hpp"

#include "lec6/error.hpp"

namespace lec6::twin {

std::vector<Exchange> run_replay(client::Master& master, std::span<const Exchange> captured,
                                 ReplayTiming timing) {
  std::vector<Exchange> out;
  out.reserve(captured.size());
  if (captured.empty()) return out;
  const Clock& clock = master.clock();
  const TimePoint base = clock.now();
  // Each query is placed by its end (when the controller has it and acts),
  // so the controller samples at the captured instant whatever the sender's
  // own delay before the first byte was.
  const auto& timing_of = master.line_timing();
  auto wire_us = [&](std::size_t bytes) {
    return std::chrono::duration_cast<std::chrono::microseconds>(timing_of.wire_time(bytes))
        .count();
  };
  const int64_t first = captured.front().query_end_us - wire_us(captured.front().query.size());
  auto since_base = [&](TimePoint t) {
    return std::chrono::duration_cast<std::chrono::microseconds>(t - base).count();
  };
  for (const auto& c : captured) {
    Exchange e;
    e.line = c.line;
    e.query = c.query;
    auto request = modbus::decode_request(c.query);
    if (!request || request->id == modbus::kBroadcastId) {
      out.push_back(std::move(e));
      continue;
    }
    if (timing == ReplayTiming::AsCaptured) {
      const TimePoint due =
          base + std::chrono::microseconds(c.query_end_us - wire_us(c.query.size()) - first);
      if (clock.now() < due) master.idle_until(due);
    }
    try {
      const modbus::ResponseFrame reply = master.exchange(*request);
      const TimePoint end = clock.now();
      const TimePoint start = end - master.last_round_trip();
      e.query_start_us = since_base(start);
      e.query_end_us = since_base(start + master.line_timing().wire_time(c.query.size()));
      e.reply = modbus::encode_response(reply);
      e.reply_end_us = since_base(end);
      e.reply_start_us =
          e.reply_end_us -
          std::chrono::duration_cast<std::chrono::microseconds>(
              master.line_timing().wire_time(e.reply->size()))
              .count();
    } catch (const Error&) {  // no reply (timeout, garbage): compared as such
      e.query_start_us = since_base(clock.now());
      e.query_end_us = e.query_start_us;
    }
    out.push_back(std::move(e));
  }
  return out;
}

}  // namespace lec6::twin
