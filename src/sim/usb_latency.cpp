// The USB adapter's latency timer (see the header).

#include "lec6/sim/usb_latency.hpp"

#include <algorithm>

namespace lec6::sim {

UsbLatency::UsbLatency(Duration latency, std::size_t packet_bytes, TimePoint origin)
    : latency_(std::max(latency, Duration::zero())),
      packet_bytes_(packet_bytes == 0 ? 1 : packet_bytes),
      origin_(origin) {}

TimePoint UsbLatency::tick_after(TimePoint t) const {
  if (t <= origin_) return origin_;
  const auto since = (t - origin_).count();
  const auto step = latency_.count();
  const auto ticks = (since + step - 1) / step;  // the first tick at or after t
  return origin_ + Duration(ticks * step);
}

void UsbLatency::seal() {
  if (open_.empty()) return;
  sealed_.push_back({*open_due_, std::move(open_)});
  open_.clear();
  open_due_.reset();
}

void UsbLatency::push(std::span<const uint8_t> bytes, TimePoint arrival) {
  if (bytes.empty()) return;
  arrival = std::max(arrival, last_arrival_);
  last_arrival_ = arrival;
  if (latency_ == Duration::zero()) {
    sealed_.push_back({arrival, modbus::Bytes(bytes.begin(), bytes.end())});
    return;
  }
  // A lump whose tick has passed went out before these bytes arrived.
  if (open_due_ && *open_due_ < arrival) seal();
  for (const uint8_t b : bytes) {
    if (open_.empty()) open_due_ = tick_after(arrival);
    open_.push_back(b);
    if (open_.size() >= packet_bytes_) {
      open_due_ = arrival;  // a full packet goes at once
      seal();
    }
  }
}

std::vector<UsbLatency::Delivery> UsbLatency::take(TimePoint now) {
  if (open_due_ && *open_due_ <= now) seal();
  std::vector<Delivery> out;
  while (!sealed_.empty() && sealed_.front().at <= now) {
    out.push_back(std::move(sealed_.front()));
    sealed_.pop_front();
  }
  return out;
}

std::optional<TimePoint> UsbLatency::next_delivery() const {
  if (!sealed_.empty()) return sealed_.front().at;
  return open_due_;
}

}  // namespace lec6::sim
