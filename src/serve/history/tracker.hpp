#pragma once
// One axis' motions as lec serve sees them (sans-I/O): the operations it runs
// (started / finished events of operations.hpp, with the move's result) and
// the telemetry reads of the axis, turned into MotionRecords.
//
//   - An operation of lec serve (HTTP, MQTT, the CLI through the daemon): its
//     record takes the kind, source and settings from the start, the outcome
//     and timeline from the result, and start position, peak and mean thrust,
//     peak speed, overshoot and distance from the telemetry samples between.
//   - A motion no operation of lec serve started (a Modbus TCP client writing
//     D9100 or DRIVE, another master on the line): BUSY rising in the
//     telemetry starts it, BUSY falling ends it (then INP, or 1 s, for the
//     settle time); its source is "telemetry". Its timeline is as fine as the
//     telemetry rate.
//
// Time points are the line's clock (a VirtualClock in tests); wall-clock
// milliseconds are given by the caller for the record's start.
// Thread safety: none (History locks around it).

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fit_offsets.hpp"
#include "lec6/clock.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/lec/state_data.hpp"
#include "motion_record.hpp"

namespace lec6::serve::history {

// A finished event of a motion op that was refused before its start reached
// the wire (servo off, soft limit, alarm already active, a stop first).
bool refused_before_start(const nlohmann::json& event, const std::string& op);

// A record's duration (BUSY's rise to its fall) from the brackets of its two
// edges: each lies between `*_after_s` and the time it was seen.
void time_from_brackets(MotionRecord& r, double up_after_s, double down_after_s);
// Its settle time (BUSY's fall to INP, issue 32 rule 5) the same way: INP
// rose between `inp_after_s` and the time it was seen; 0 when one poll saw
// both (timing_test.cpp InpAfterBusyFellGivesASettleTimeWithinItsBracket).
void settle_from_brackets(MotionRecord& r, double down_after_s, double inp_after_s);
inline constexpr double kNoDuration = std::numeric_limits<double>::quiet_NaN();

// Issue 32: a motion held for a weekend kept every sample (~55 MB per axis)
// and was one 48 h motion. Samples past kMaxSamples merge in pairs (peaks
// kept, tracker_test.cpp ALongMotionKeepsBoundedSamples); a motion whose
// carriage stays still with BUSY on for kRestCloses ends there, "stopped",
// and the rest of that BUSY is not another motion: one seen in the telemetry
// (AMotionLeftAtRestIsClosedNotCountedForTheWholeHold) or an operation of
// lec serve held there (AnOperationHeldForHoursIsClosedAtRestWithBoundedMemory).
inline constexpr std::size_t kMaxSamples = 4096;
inline constexpr Duration kRestCloses = std::chrono::seconds(60);

class MotionTracker {
 public:
  explicit MotionTracker(std::string axis) : axis_(std::move(axis)) {}

  // An operations event ("started" / "finished", operations.hpp) for this
  // axis. Returns the record of a motion that finished.
  std::optional<MotionRecord> op_event(const nlohmann::json& event, TimePoint at, int64_t wall_ms);
  std::size_t samples_kept() const noexcept { return motion_ ? motion_->samples.size() : 0; }
  // A telemetry read of the axis: its state and flags as the cache has them,
  // its reply's end `at` and its start `sent` (nullopt: at). An edge a read
  // saw happened after the previous flags read's start and before this
  // one's end (TelemetryBracketsOpenWhenThePreviousReadBegan).
  std::optional<MotionRecord> telemetry(const std::optional<lec::StateData>& state,
                                        const std::optional<lec::StatusFlags>& flags, TimePoint at,
                                        int64_t wall_ms, std::optional<TimePoint> sent = {});

 private:
  struct Sample {
    TimePoint at;
    double position_mm, speed_mm_s, thrust_pct;
    TimePoint sent{};  // its query's start on the wire; {}: not known (no window)
  };
  struct Motion {
    bool by_telemetry = false;
    MotionRecord record;
    TimePoint started{};
    std::optional<TimePoint> busy_down;
    std::optional<double> up_after_s, down_after_s;  // the brackets' early ends (telemetry)
    std::optional<TimePoint> rest_since;             // BUSY on, the carriage still (a hold)
    std::optional<TimePoint> busy_seen;              // the first read with BUSY on
    // Any read of its flags (telemetry's or an operation's) brackets BUSY's
    // edges on the samples' clock: the last BUSY = 0 read's start before the
    // first BUSY = 1 read; the last BUSY = 1 read's start, and the first
    // BUSY = 0 read's end after it.
    std::optional<TimePoint> low_before_sent, high_last_sent, low_after_at;
    bool interrupted = false;  // a stop, hold or reset of ours came during it: not one trapezoid
    std::vector<Sample> samples;
  };
  MotionRecord finish(Motion& m, std::optional<double> final_mm);
  // A reached positioning move's duration from its position samples against
  // the profile it was given (profile_fit.hpp), corrected by what the polls
  // say the fit cannot see (fit_offsets.hpp), where that is narrower than the
  // BUSY brackets.
  void time_from_positions(const Motion& m, const nlohmann::json& event, MotionRecord& r,
                           double up_after_s, double down_after_s);
  static void keep(Motion& m, const Sample& s);  // bounded: pairs merge past kMaxSamples

  std::string axis_;
  std::optional<Motion> motion_;
  std::optional<Sample> last_;
  bool last_busy_ = false;
  std::optional<TimePoint> last_flags_at_;  // the last flags read's start
  bool wait_idle_ = false;  // after an operation: BUSY must fall before telemetry starts one
  FitOffsets offsets_;
};

}  // namespace lec6::serve::history
