#pragma once
// The scheduler's test harness on a virtual clock: the "line" is the test,
// answering each dispatch by hand (scheduler_test.cpp, scheduler_stop_test.cpp).

#include <algorithm>
#include <vector>

#include "line/scheduler.hpp"

namespace lec6::serve::scheduler_testing {

using namespace std::chrono_literals;
using client::TransportError;
using client::TransportErrorKind;
using modbus::ReadBitsRequest;
using modbus::ReadRegistersRequest;

inline const modbus::Request kReadState = ReadRegistersRequest{0x9000, 7};
inline const TransportError kTimeout(TransportErrorKind::Timeout,
                                     "no reply from ID 9 within 65.0 ms");

// A reply the way a controller would give it, with recognisable values.
inline modbus::ResponseFrame answer(const Dispatch& d) {
  if (const auto* r = std::get_if<ReadRegistersRequest>(&d.frame.pdu)) {
    std::vector<uint16_t> v(r->count);
    for (uint16_t i = 0; i < r->count; ++i) v[i] = static_cast<uint16_t>(d.frame.id * 100 + i);
    return {d.frame.id, modbus::ReadRegistersResponse{v}};
  }
  if (const auto* b = std::get_if<ReadBitsRequest>(&d.frame.pdu)) {
    modbus::Bytes packed((b->count + 7u) / 8u, 0);
    if (b->function == modbus::FunctionCode::ReadInputs) packed[1] = 0x02;  // SVRE
    return {d.frame.id, modbus::ReadBitsResponse{b->function, packed}};
  }
  if (const auto* c = std::get_if<modbus::WriteCoilRequest>(&d.frame.pdu)) {
    return {d.frame.id, modbus::WriteCoilResponse{c->coil, c->value}};
  }
  return {d.frame.id, modbus::WriteMultipleResponse{}};
}

struct Harness {
  explicit Harness(SchedulerConfig c = {}) : s(std::move(c), clock.now()) {}
  VirtualClock clock{TimePoint{} + 1s};
  Scheduler s;
  std::vector<JobResult> results;

  Job job(Priority p, uint8_t id, modbus::Request r = kReadState) {
    Job j;
    j.priority = p;
    j.frame = {id, std::move(r)};
    j.done = [this](const JobResult& res) { results.push_back(res); };
    return j;
  }
  // Runs the next dispatch: answered by `id`s that are alive, 10 ms each.
  std::optional<Dispatch> step(const std::vector<uint8_t>& dead = {}) {
    auto d = s.next(clock.now());
    if (!d) return d;
    const TimePoint start = clock.now();
    const bool is_dead = std::find(dead.begin(), dead.end(), d->frame.id) != dead.end();
    clock.advance(is_dead ? 65ms : 10ms);
    is_dead ? s.failed(kTimeout, start, clock.now()) : s.completed(answer(*d), start, clock.now());
    for (auto& c : s.take_completions()) c.done(c.result);
    return d;
  }
  // Runs the line for `d` of virtual time: dispatches, or jumps to the next wake-up.
  std::vector<Dispatch> run_for(Duration d, const std::vector<uint8_t>& dead = {}) {
    std::vector<Dispatch> out;
    const TimePoint end = clock.now() + d;
    while (clock.now() < end) {
      if (auto x = step(dead)) {
        out.push_back(*x);
        continue;
      }
      const auto w = s.wake_at();
      clock.set(w && *w > clock.now() && *w < end ? *w : end);
    }
    return out;
  }
};

}  // namespace lec6::serve::scheduler_testing
