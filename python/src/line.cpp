#include "line.hpp"

#include "lec6/client/errors.hpp"

namespace lec6::python {

SharedLine::Turn::Turn(const SharedLine& line) : line_(line) {
  std::unique_lock lock(line_.mutex_);
  const uint64_t mine = line_.next_ticket_++;
  line_.turn_.wait(lock, [&] { return line_.serving_ == mine; });
}

SharedLine::Turn::~Turn() {
  {
    std::lock_guard lock(line_.mutex_);
    ++line_.serving_;
  }
  line_.turn_.notify_all();
}

SharedLine::SharedLine(std::shared_ptr<void> owner, client::Master& inner)
    : owner_(std::move(owner)),
      inner_(&inner),
      description_(inner.describe()),
      timing_(inner.line_timing()) {}

modbus::ResponseFrame SharedLine::exchange(const modbus::RequestFrame& frame) {
  Turn turn(*this);
  if (!inner_) {
    throw client::TransportError(client::TransportErrorKind::Port,
                                 description_ + ": the bus was closed");
  }
  struct Snapshot {  // also when the exchange throws: timeouts count
    SharedLine& line;
    ~Snapshot() {
      std::lock_guard lock(line.stats_mutex_);
      line.stats_ = line.inner_->stats();
      line.last_round_trip_ = line.inner_->last_round_trip();
    }
  } snapshot{*this};
  return inner_->exchange(frame);
}

client::LinkStats SharedLine::stats() const {
  std::lock_guard lock(stats_mutex_);
  return stats_;
}

client::LinkStats SharedLine::totals() const {
  client::LinkStats s = stats();
  s.retries += retries_.load();
  s.exceptions += exceptions_.load();
  return s;
}

Duration SharedLine::last_round_trip() const {
  std::lock_guard lock(stats_mutex_);
  return last_round_trip_;
}

void SharedLine::close() {
  Turn turn(*this);
  if (!inner_) return;
  inner_ = nullptr;
  owner_.reset();
}

bool SharedLine::closed() const {
  Turn turn(*this);
  return inner_ == nullptr;
}

void SharedLine::count(uint64_t retries, uint64_t exceptions) {
  retries_ += retries;
  exceptions_ += exceptions;
}

}  // namespace lec6::python
