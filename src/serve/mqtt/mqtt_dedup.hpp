#pragma once
// The commands an axis was given over MQTT, by id, so that a command
// delivered twice (QoS 1 redelivery, a client that retries) runs once: a
// repeat of a finished id gets the earlier result again, a repeat of one
// still running gets nothing more (its result comes when it ends).
//
// Bounded: finished entries go after `max_age`, and the oldest finished ones
// when there are more than `max_entries` or their results pass `max_bytes`.
// A running entry is never dropped, so a repeat can never start a second run.
// The guarantee is therefore "at most once per id within the window": an id
// repeated after an hour, or after 1024 newer commands, runs again.
//
// Thread safety: none; the bridge locks around it.

#include <cstddef>
#include <deque>
#include <map>
#include <string>
#include <vector>

#include "lec6/clock.hpp"

namespace lec6::serve {

// Where a requester asked for the result (MQTT 5 response topic).
struct ReplyTo {
  std::string topic;
  std::string correlation;
};

class CommandLog {
 public:
  struct Limits {
    std::size_t max_entries = 1024;
    Duration max_age = std::chrono::hours(1);
    std::size_t max_bytes = 4u << 20;
  };
  enum class Seen { New, Running, Done };
  struct Lookup {
    Seen seen = Seen::New;
    std::string result;  // Done: the earlier result
  };

  CommandLog() = default;
  explicit CommandLog(Limits limits) : limits_(limits) {}

  // Looks `id` up. A repeat of a running id adds its `reply` to those told
  // when it ends. New: nothing is recorded (the command may yet be refused).
  Lookup find(const std::string& id, TimePoint now, const std::vector<ReplyTo>& reply = {});
  // Records a new id as running, with the replies waiting for its result.
  void start(const std::string& id, TimePoint now, std::vector<ReplyTo> reply = {});
  // Records the result of a running id; returns the replies waiting for it.
  std::vector<ReplyTo> finish(const std::string& id, std::string result, TimePoint now);

  std::size_t size() const noexcept { return entries_.size(); }
  std::size_t bytes() const noexcept { return bytes_; }

 private:
  struct Entry {
    bool running = true;
    std::string result;
    TimePoint at{};  // when it finished (or began, while running)
    std::vector<ReplyTo> replies;
  };
  void evict(TimePoint now);

  Limits limits_;
  std::map<std::string, Entry, std::less<>> entries_;
  std::deque<std::string> finished_;  // ids in the order they finished
  std::size_t bytes_ = 0;
};

}  // namespace lec6::serve
