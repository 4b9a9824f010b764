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
  return inner_->exchange(frame);
}

client::LinkStats SharedLine::stats() const {
  Turn turn(*this);
  return inner_ ? inner_->stats() : final_stats_;
}

client::LinkStats SharedLine::totals() const {
  client::LinkStats s = stats();
  s.retries += retries_.load();
  s.exceptions += exceptions_.load();
  return s;
}

Duration SharedLine::last_round_trip() const {
  Turn turn(*this);
  return inner_ ? inner_->last_round_trip() : Duration{};
}

void SharedLine::close() {
  Turn turn(*this);
  if (!inner_) return;
  final_stats_ = inner_->stats();
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
