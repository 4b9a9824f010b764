#include "cli/doctor_line.hpp"

#include <array>
#include <fstream>

#include "lec6/client/link.hpp"
#include "lec6/lec/memory_map.hpp"

namespace lec6::cli::doctor_line {

LineProbe::LineProbe(std::unique_ptr<twin::OpenPort> port, const modbus::LineTiming& timing,
                     std::function<void(Duration)> wait)
    : port_(std::move(port)), timing_(timing), wait_(std::move(wait)) {
  link_ = port_->master().link();
  if (!link_) throw InvalidArgument("lec doctor probes a line it owns (a serial port)");
}

modbus::Bytes LineProbe::listen(Duration d) {
  modbus::Bytes heard;
  std::array<uint8_t, 512> buf{};
  const TimePoint until = link_->clock().now() + d;
  while (link_->clock().now() < until) {
    const std::size_t n = link_->read_some(buf, until);
    heard.insert(heard.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
  }
  return heard;
}

LineProbe::Heard LineProbe::exchange(const modbus::Bytes& query, std::size_t reply_bytes,
                                     Duration margin, Duration gap, std::size_t split_at) {
  using client::doctor::ReplyKind;
  // The silent interval before a query (and a little more for the twin's wake-ups).
  wait_(timing_.silent_interval() + std::chrono::microseconds(500));
  link_->discard_input();
  Heard h;
  const TimePoint start = link_->clock().now();
  if (gap > Duration::zero() && split_at < query.size()) {
    const std::span<const uint8_t> q(query);
    link_->write(q.first(split_at));
    // write() returns when the bytes have left; an adapter may still hold
    // them for their wire time: wait that too, so the gap is at least `gap`.
    wait_(gap + timing_.wire_time(split_at));
    link_->write(q.subspan(split_at));
  } else {
    link_->write(query);
  }
  const TimePoint deadline = link_->clock().now() + timing_.response_time(reply_bytes) + margin;
  std::array<uint8_t, 512> buf{};
  while (link_->clock().now() < deadline) {
    const std::size_t n = link_->read_some(buf, deadline);
    if (n == 0) continue;
    h.bytes.insert(h.bytes.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
    const auto r = client::doctor::classify_exchange(query, h.bytes);
    if (r.kind == ReplyKind::Good || r.kind == ReplyKind::Exception || r.kind == ReplyKind::Crc) {
      h.round_trip = link_->clock().now() - start;
      break;
    }
  }
  h.result = client::doctor::classify_exchange(query, h.bytes);
  return h;
}

modbus::Bytes state_query(uint8_t id) {
  return *modbus::encode_request(
      {id, modbus::ReadRegistersRequest{lec::kStateData, lec::kStateDataRegisters}});
}

std::optional<LatencyTimer> read_latency_timer(const std::string& device,
                                               const std::filesystem::path& sysfs_root) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path real = fs::canonical(device, ec);  // /dev/serial/by-id/... -> /dev/ttyUSB0
  const std::string name = (ec ? fs::path(device) : real).filename().string();
  if (name.empty()) return std::nullopt;
  LatencyTimer t;
  t.file = sysfs_root / "bus" / "usb-serial" / "devices" / name / "latency_timer";
  std::ifstream in(t.file);
  if (!in || !(in >> t.ms)) return std::nullopt;
  return t;
}

bool set_latency_timer_1ms(const LatencyTimer& t) {
  std::ofstream out(t.file);
  if (!out) return false;
  out << "1\n";
  out.flush();
  return static_cast<bool>(out);
}

}  // namespace lec6::cli::doctor_line
