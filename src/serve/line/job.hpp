#pragma once
// A request for the line, as its submitters hand it to the scheduler, and as
// it waits in a queue.

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "lec6/clock.hpp"
#include "lec6/modbus/pdu.hpp"
#include "line/priority.hpp"

namespace lec6::serve {

struct JobResult;
using JobId = uint64_t;
// Who sent a job: a Modbus TCP connection, one operation (HTTP, MQTT, CLI,
// Python through the daemon). Client commands take turns by source
// (command_turns.hpp); 0: the daemon's own, one source.
using JobSource = uint64_t;
// A source no job had before (thread-safe).
JobSource new_job_source();

struct Job {
  Priority priority = Priority::Command;
  JobSource source = 0;
  modbus::RequestFrame frame;
  std::function<void(const JobResult&)> done;  // called once, by the driver, outside its lock
  // > 0: a read of a telemetry block may be answered from the cache if no
  // older, and taken no earlier than `not_before` (what the client last saw).
  Duration max_cache_age{};
  TimePoint not_before{};
  // Exchanges to try on a line fault (timeout, CRC, framing); reads may retry, starts never.
  int attempts = 1;
  // A resend of a write whose reply was lost (LineMaster): when the scheduler
  // took its first attempt. A stop accepted after that supersedes it as it
  // would have superseded the first attempt (scheduler.cpp).
  std::optional<TimePoint> first_submitted{};
  // A write of one of lec serve's operations (LineMaster::count_from): when
  // its command was accepted. A stop accepted after that supersedes the
  // command's starts however late they are submitted (a move's start comes
  // after its reads: a stop that came meanwhile must still win; scheduler.cpp).
  std::optional<TimePoint> command_accepted{};
  // The other controllers of the work this write belongs to (a machine cycle
  // of lec serve's: its axes on this line): a hard stop to any of them
  // supersedes this write's starts as one to its own controller does (a
  // reviewer's finding: a stop of axis z left the start of axis x already
  // queued to go, and x moved after the stop).
  std::vector<uint8_t> stop_group;
};

// A job waiting for the wire.
struct Queued {
  JobId id = 0;
  Job job;
  TimePoint submitted{};
  bool retry = false;  // a further attempt (its first one's wait is counted)
};

}  // namespace lec6::serve
