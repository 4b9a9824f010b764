#include "line/line_master.hpp"

#include <fmt/format.h>

#include <future>

#include "lec6/client/interrupt.hpp"

namespace lec6::serve {

Priority priority_of(const modbus::RequestFrame& frame, Priority reads, Priority writes) {
  if (client::stops_or_releases(frame.pdu)) return Priority::Emergency;  // the one rule
  return modbus::is_write(frame.pdu) ? writes : reads;
}

client::TransportError transport_error(const JobResult& r) {
  return client::TransportError(r.error_kind,
                                r.error.empty() ? std::string(failure_name(r.failure)) : r.error);
}

LineMaster::LineMaster(Line& line, Priority reads, Priority writes)
    : line_(line), reads_(reads), writes_(writes) {}

std::string LineMaster::describe() const {
  return fmt::format("{} (lec serve line {})", line_.describe(), line_.options().name);
}

modbus::ResponseFrame LineMaster::exchange(const modbus::RequestFrame& frame) {
  auto promise = std::make_shared<std::promise<JobResult>>();
  auto result = promise->get_future();
  Job job;
  job.priority = priority_of(frame, reads_, writes_);
  job.source = source_;
  job.frame = frame;
  const bool resend = lost_write_ && lost_write_->first == frame;
  if (resend) job.first_submitted = lost_write_->second;
  if (modbus::is_write(frame.pdu)) {
    job.command_accepted = accepted_;
    job.stop_group = stop_group_;
  }
  job.done = [promise](const JobResult& r) { promise->set_value(r); };
  line_.submit(std::move(job));
  const JobResult r = result.get();  // the line always answers: on the wire, or failed
  ++stats_.transactions;
  // Kept across reads: an INC move reads the position before it decides
  // to resend its start (actuator_move.cpp; a reviewer's finding). Dropped
  // when a write reaches the controller, or another write is sent.
  if (modbus::is_write(frame.pdu)) {
    if (r.failure == Failure::NoAnswer || r.failure == Failure::Offline) {
      if (!resend) lost_write_.emplace(frame, r.submitted);
    } else {
      lost_write_.reset();
    }
  }
  if (r.failure == Failure::Superseded) throw client::Superseded(r.error);
  if (r.failure != Failure::None) {
    if (r.error_kind == client::TransportErrorKind::Timeout) ++stats_.timeouts;
    throw transport_error(r);
  }
  last_round_trip_ = r.finished - r.started;
  last_wire_times_ = client::WireTimes{r.started, r.finished};
  return *r.reply;
}

}  // namespace lec6::serve
