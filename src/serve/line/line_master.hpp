#pragma once
// A client::Master whose exchanges queue on a lec serve Line: the library's
// Client and Actuator (every operation sequence of the manual, with its
// completion logic) run unchanged inside the daemon, while the line's
// scheduler decides when each of their transactions goes out.
//
// Priorities: stops (client::stops_or_releases, the one rule) go first
// (Priority::Emergency); other writes at `writes`; reads at `reads` (an
// operation polling for completion reads at Priority::Completion).
//
// Thread safety: exchange() blocks its caller until the line answered; one
// thread at a time per LineMaster (give each operation its own).

#include <atomic>
#include <functional>

#include "lec6/client/master.hpp"
#include "line/line.hpp"

namespace lec6::serve {

// The priority a client's request gets: a stop (client::stops_or_releases)
// is always Emergency; other writes `writes`, reads `reads`. Every front-end
// (operations, Modbus TCP, RTU over TCP) classifies with this.
Priority priority_of(const modbus::RequestFrame& frame, Priority reads, Priority writes);

// What a failed job means to a Client: the TransportError it would have met
// on a wire of its own.
client::TransportError transport_error(const JobResult& result);

class LineMaster final : public client::Master {
 public:
  LineMaster(Line& line, Priority reads, Priority writes);

  modbus::ResponseFrame exchange(const modbus::RequestFrame& frame) override;
  const Clock& clock() const override { return line_.clock(); }
  std::string describe() const override;
  // The operation this master serves was accepted at `accepted` (the line's
  // clock): its writes carry it (Job::command_accepted), so a stop accepted
  // after the command supersedes the command's starts, however late they come.
  void count_from(TimePoint accepted) { accepted_ = accepted; }
  // The controllers of the work this master serves (a cycle's axes on this
  // line): a hard stop to any of them supersedes its starts (Job::stop_group).
  void stop_group(std::vector<uint8_t> ids) { stop_group_ = std::move(ids); }
  // From now on its reads go at Emergency, as a stop's own reads do (the
  // work it serves is stopping: its axes are read until seen at rest).
  void reads_urgent() { reads_ = Priority::Emergency; }
  client::LinkStats stats() const override { return stats_; }
  Duration last_round_trip() const override { return last_round_trip_; }
  // The line's own times (issue 32): the exchange's start and its reply's
  // end on the line's thread (a cached answer: when its block was read, and
  // when it was answered), not when exchange() returned here.
  std::optional<client::WireTimes> last_wire_times() const override { return last_wire_times_; }
  const modbus::LineTiming& line_timing() const override { return line_.timing(); }

 private:
  Line& line_;
  Priority reads_;
  Priority writes_;
  // One operation's commands keep their order and take turns with other
  // clients' (command_turns.hpp).
  JobSource source_ = new_job_source();
  client::LinkStats stats_;
  Duration last_round_trip_{};
  std::optional<client::WireTimes> last_wire_times_;
  // The last write whose reply was lost, and when the line took its first
  // attempt: a Client resends it as a new job, which a stop accepted after
  // that first attempt supersedes all the same (Job::first_submitted).
  std::optional<std::pair<modbus::RequestFrame, TimePoint>> lost_write_;
  std::optional<TimePoint> accepted_;
  std::vector<uint8_t> stop_group_;
};

}  // namespace lec6::serve
