#include "lec6/client/shared_master.hpp"

#include "lec6/client/errors.hpp"

namespace lec6::client {

SharedMaster::Turn::Turn(const SharedMaster& line) : line_(line) {
  std::unique_lock lock(line_.mutex_);
  const uint64_t mine = line_.next_ticket_++;
  line_.turn_.wait(lock, [&] { return line_.serving_ == mine; });
}

SharedMaster::Turn::~Turn() {
  {
    std::lock_guard lock(line_.mutex_);
    ++line_.serving_;
  }
  line_.turn_.notify_all();
}

SharedMaster::SharedMaster(Master& inner)
    : inner_(&inner),
      clock_(inner.clock()),
      description_(inner.describe()),
      timing_(inner.line_timing()),
      stats_(inner.stats()) {}

SharedMaster::SharedMaster(std::shared_ptr<void> owner, Master& inner, const Clock& clock)
    : owner_(std::move(owner)),
      inner_(&inner),
      clock_(clock),
      description_(inner.describe()),
      timing_(inner.line_timing()),
      stats_(inner.stats()) {}

modbus::ResponseFrame SharedMaster::exchange(const modbus::RequestFrame& frame) {
  Turn turn(*this);
  if (!inner_) {
    throw TransportError(TransportErrorKind::Port, description_ + ": the line was closed");
  }
  struct Snapshot {  // also when the exchange throws: timeouts count
    SharedMaster& line;
    ~Snapshot() {
      std::lock_guard lock(line.stats_mutex_);
      line.stats_ = line.inner_->stats();
      line.last_round_trip_ = line.inner_->last_round_trip();
    }
  } snapshot{*this};
  return inner_->exchange(frame);
}

LinkStats SharedMaster::stats() const {
  std::lock_guard lock(stats_mutex_);
  return stats_;
}

LinkStats SharedMaster::totals() const {
  LinkStats s = stats();
  s.retries += retries_.load();
  s.exceptions += exceptions_.load();
  return s;
}

Duration SharedMaster::last_round_trip() const {
  std::lock_guard lock(stats_mutex_);
  return last_round_trip_;
}

void SharedMaster::close() {
  Turn turn(*this);
  if (!inner_) return;
  inner_ = nullptr;
  owner_.reset();
}

bool SharedMaster::closed() const {
  Turn turn(*this);
  return inner_ == nullptr;
}

std::size_t SharedMaster::waiting() const {
  std::lock_guard lock(mutex_);
  const uint64_t taken = next_ticket_ - serving_;  // the holder's included
  return taken > 0 ? static_cast<std::size_t>(taken - 1) : 0;
}

void SharedMaster::count(uint64_t retries, uint64_t exceptions) {
  retries_ += retries;
  exceptions_ += exceptions;
}

}  // namespace lec6::client
