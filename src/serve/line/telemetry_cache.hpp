#pragma once
// What lec serve last read from each controller, so that state reads from
// many clients cost the line nothing (issue: fifty SCADA clients polling).
//
// Four blocks per axis, the ones lec serve polls: X40–X4F (flags, FC02),
// D9000–D9006 (state, FC03), Y10–Y30 (controls, FC01, as Client::
// read_controls reads them) and the alarm history D0380×64. Any successful read that covers a block
// exactly refreshes it, whoever asked. A read is answered from the cache only when it lies inside
// one block that is fresh enough and was taken after the last write to that controller (a client
// always reads its own writes).
//
// Thread safety: none; the scheduler that owns it is driven by one thread.

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include "lec6/clock.hpp"
#include "lec6/lec/alarm_check.hpp"
#include "lec6/lec/alarms.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/lec/state_data.hpp"
#include "lec6/modbus/pdu.hpp"

namespace lec6::serve {

enum class Block : uint8_t { Flags, State, Controls, Alarms };
inline constexpr std::size_t kBlocks = 4;

// The read that fills a block (what telemetry sends).
modbus::Request block_request(Block b);

struct CachedBlock {
  std::vector<uint16_t> values;  // registers, or one 0/1 per bit
  TimePoint taken{};             // when the read that filled it started
};

// One axis as the cache knows it. `flags` is in the manual's meaning (X4F =
// 1: alarm present), turned so with the axis's alarm polarity
// (lec::normalise_alarm); the cached blocks, which answer Modbus clients,
// keep the wire's bits.
struct AxisSnapshot {
  std::optional<lec::StatusFlags> flags;
  std::optional<lec::StateData> state;
  std::optional<lec::ControlFlags> controls;
  std::optional<lec::AlarmHistory> alarms;
  TimePoint flags_at{}, state_at{}, controls_at{}, alarms_at{};
};

class TelemetryCache {
 public:
  // A successful read to `id` that started at `started`: refreshes the block
  // it covers exactly (if any). Returns the block refreshed.
  std::optional<Block> update(uint8_t id, const modbus::Request& request,
                              const modbus::Response& response, TimePoint started);
  // A write to `id` (or to every ID, for a broadcast) completed at `at`:
  // older blocks no longer answer reads.
  void invalidate(uint8_t id, TimePoint at);
  void invalidate_all(TimePoint at);

  // The reply to `request` from the cache, if a block covers it, is no older
  // than `max_age` at `now`, was taken after the last write, and not before
  // `not_before` (a client must never see older data than it already saw:
  // its flags from the line, then its state from an older cache, would lie).
  struct Hit {
    modbus::Response response;
    TimePoint taken;
  };
  std::optional<Hit> lookup(uint8_t id, const modbus::Request& request, Duration max_age,
                            TimePoint now, TimePoint not_before = TimePoint{}) const;

  // The age of a block (nullopt: never read, or invalidated).
  std::optional<Duration> age(uint8_t id, Block b, TimePoint now) const;
  AxisSnapshot snapshot(uint8_t id) const;
  // How `id` reports X4F (AxisConfig::alarm_polarity); active-high unless set.
  void set_alarm_polarity(uint8_t id, lec::AlarmPolarity p) { polarity_[id] = p; }

 private:
  struct Axis {
    std::array<std::optional<CachedBlock>, kBlocks> blocks;
    TimePoint written{};  // the last write's completion
  };
  const CachedBlock* usable(const Axis& a, Block b) const;
  std::map<uint8_t, Axis> axes_;
  std::map<uint8_t, lec::AlarmPolarity> polarity_;
};

}  // namespace lec6::serve
