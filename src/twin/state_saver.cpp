#include "twin/state_saver.hpp"

#include "lec6/twin/state_file_io.hpp"

#include <algorithm>
#include <system_error>

namespace lec6::twin {

StateSaver::StateSaver(const sim::Bus& bus, Options options)
    : bus_(bus), options_(std::move(options)) {}

StateSaver::~StateSaver() {
  stop();
}

uint64_t StateSaver::generation() const {
  uint64_t g = 0;
  for (uint8_t id : bus_.ids()) g += bus_.find(id)->eeprom_generation();
  return g;
}

sim::EepromSet StateSaver::snapshot() const {
  sim::EepromSet s = options_.carry;
  for (uint8_t id : bus_.ids()) s.insert_or_assign(id, bus_.find(id)->eeprom());
  return s;
}

void StateSaver::start() {
  if (options_.path.empty()) return;
  saved_generation_ = generation();
  writer_ = std::thread([this] { writer_loop(); });
}

void StateSaver::writer_loop() {
  std::unique_lock lock(mutex_);
  for (;;) {
    cv_.wait(lock, [&] { return pending_.has_value() || quit_; });
    if (!pending_) return;
    sim::EepromSet state = std::move(*pending_);
    pending_.reset();
    lock.unlock();
    auto saved = save_state_file(options_.path, state);
    if (!saved) {
      ++failures_;
      if (options_.warn) options_.warn(saved.error());
    }
    lock.lock();
  }
}

void StateSaver::submit(TimePoint now) {
  {
    std::lock_guard lock(mutex_);
    pending_ = snapshot();  // replaces a save not yet written: the newest wins
  }
  cv_.notify_one();
  ++saves_;
  saved_generation_ = generation();
  last_save_ = now;
  have_saved_ = true;
  save_at_.reset();
}

void StateSaver::check(TimePoint now) {
  if (options_.path.empty()) return;
  if (!save_at_ && generation() != saved_generation_) {
    save_at_ = have_saved_ ? std::max(now, last_save_ + options_.interval) : now;
  }
  if (save_at_ && *save_at_ <= now) submit(now);
}

void StateSaver::final_save(TimePoint now) {
  if (options_.path.empty() || !writer_.joinable()) return;
  std::error_code ec;
  if (generation() != saved_generation_ || !std::filesystem::exists(options_.path, ec)) {
    submit(now);
  }
}

void StateSaver::stop() {
  if (!writer_.joinable()) return;
  {
    std::lock_guard lock(mutex_);
    quit_ = true;  // the loop writes what is pending first
  }
  cv_.notify_one();
  writer_.join();
}

}  // namespace lec6::twin
