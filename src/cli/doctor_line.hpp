#pragma once
// lec doctor's I/O (private to cmd_doctor.cpp): the port opened at one baud
// rate, raw exchanges whose bytes are kept (echo, noise, reply), listening,
// and the USB adapter's latency timer in sysfs. The judgement is in
// client/doctor (sans-I/O).

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "lec6/client/doctor.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/twin/open_port.hpp"

namespace lec6::cli::doctor_line {

// The port at one baud, with no echo discard (we want to see the echo) unless asked.
class LineProbe {
 public:
  // `port` opened at timing.baud; `wait` lets time pass on its link's clock.
  LineProbe(std::unique_ptr<twin::OpenPort> port, const modbus::LineTiming& timing,
            std::function<void(Duration)> wait);
  client::Link& link() { return *link_; }
  client::Master& master() { return port_->master(); }
  const modbus::LineTiming& timing() const { return timing_; }

  // Everything heard for `d` while we send nothing.
  modbus::Bytes listen(Duration d);

  struct Heard {
    modbus::Bytes bytes;
    client::doctor::ExchangeResult result;
    Duration round_trip{};  // first byte sent -> reply complete (sound replies)
  };
  // Waits Ts of quiet, sends `query` and collects everything until the reply
  // is complete or the window (Tx + margin) has passed.
  // With `gap` > 0: the query leaves in two parts, `gap` apart on the wire
  // (after the first part's wire time), split after `split_at` bytes: a
  // controller whose silent interval Ts is shorter than the gap sees two
  // bad frames and stays silent.
  Heard exchange(const modbus::Bytes& query, std::size_t reply_bytes, Duration margin,
                 Duration gap = {}, std::size_t split_at = 4);

 private:
  std::unique_ptr<twin::OpenPort> port_;
  client::Link* link_ = nullptr;
  modbus::LineTiming timing_;
  std::function<void(Duration)> wait_;
};

// D9000 x 7 (state data) to `id`: the probe every check uses (its reply,
// 19 bytes, never looks like the query, unlike an FC08 echo).
modbus::Bytes state_query(uint8_t id);
inline constexpr std::size_t kStateReplyBytes = 5 + 2 * 7;

struct LatencyTimer {
  int ms = 0;
  std::filesystem::path file;
};
// The USB serial adapter's latency_timer behind `device`, if it has one.
std::optional<LatencyTimer> read_latency_timer(const std::string& device,
                                               const std::filesystem::path& sysfs_root = "/sys");
// Writes 1 ms; false when refused (permission).
bool set_latency_timer_1ms(const LatencyTimer& t);

}  // namespace lec6::cli::doctor_line
