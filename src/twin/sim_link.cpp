#include "lec6/twin/sim_link.hpp"

#include <algorithm>
#include <cstring>
#include <thread>

namespace lec6::twin {

SimLink::SimLink(sim::Bus& bus, VirtualClock& clock) : bus_(bus), clock_(clock), virtual_(&clock) {}
SimLink::SimLink(sim::Bus& bus, const SteadyClock& clock) : bus_(bus), clock_(clock) {}

std::string SimLink::describe() const {
  return virtual_ ? "in-process twin (virtual time)" : "in-process twin";
}

void SimLink::wait_until(TimePoint t) {
  if (virtual_) {
    if (t > virtual_->now()) virtual_->set(t);
    return;
  }
  std::this_thread::sleep_until(std::chrono::steady_clock::time_point(
      std::chrono::duration_cast<std::chrono::steady_clock::duration>(t.time_since_epoch())));
}

void SimLink::write(std::span<const uint8_t> bytes) {
  // The query occupies the wire for its length; its last byte arrives then.
  // Fast timing adds no wire time, as its replies take none (digest §1).
  if (bus_.line().timing != sim::Timing::Fast)
    wait_until(clock_.now() + bus_.line().line.wire_time(bytes.size()));
  bus_.receive(bytes, clock_.now());
}

void SimLink::collect_replies() {
  bus_.advance(clock_.now());
  for (auto& r : bus_.take_replies(clock_.now())) incoming_.push_back({r.end, std::move(r.bytes)});
}

std::size_t SimLink::read_some(std::span<uint8_t> buffer, TimePoint deadline) {
  for (;;) {
    collect_replies();
    if (!incoming_.empty()) {
      Arrival& next = incoming_.front();
      // What has arrived by now is there to read, also past the deadline (a
      // reader that looks late, as a real port gives what its buffer holds).
      if (next.at > std::max(deadline, clock_.now())) {
        wait_until(std::max(deadline, clock_.now()));
        return 0;
      }
      wait_until(next.at);
      const std::size_t n = std::min(buffer.size(), next.bytes.size());
      std::memcpy(buffer.data(), next.bytes.data(), n);
      next.bytes.erase(next.bytes.begin(), next.bytes.begin() + static_cast<std::ptrdiff_t>(n));
      if (next.bytes.empty()) incoming_.pop_front();
      return n;
    }
    const auto due = bus_.next_deadline();
    if (!due || *due > deadline) {
      wait_until(std::max(deadline, clock_.now()));
      collect_replies();
      if (!incoming_.empty() && incoming_.front().at <= clock_.now()) continue;
      return 0;
    }
    wait_until(std::max(*due, clock_.now()));
  }
}

void SimLink::discard_input() {
  collect_replies();
  while (!incoming_.empty() && incoming_.front().at <= clock_.now()) incoming_.pop_front();
}

}  // namespace lec6::twin
