#include "mqtt/mqtt_dedup.hpp"

namespace lec6::serve {

CommandLog::Lookup CommandLog::find(const std::string& id, TimePoint now,
                                    const std::vector<ReplyTo>& reply) {
  evict(now);
  const auto it = entries_.find(id);
  if (it == entries_.end()) return {Seen::New, {}};
  Entry& e = it->second;
  if (e.running) {
    for (const auto& r : reply) {
      bool known = false;
      for (const auto& w : e.replies)
        known = known || (w.topic == r.topic && w.correlation == r.correlation);
      if (!known) e.replies.push_back(r);
    }
    return {Seen::Running, {}};
  }
  return {Seen::Done, e.result};
}

void CommandLog::start(const std::string& id, TimePoint now, std::vector<ReplyTo> reply) {
  entries_.emplace(id, Entry{true, {}, now, std::move(reply)});  // no-op for a known id
}

std::vector<ReplyTo> CommandLog::finish(const std::string& id, std::string result, TimePoint now) {
  const auto it = entries_.find(id);
  if (it == entries_.end() || !it->second.running) return {};
  Entry& e = it->second;
  e.running = false;
  e.at = now;
  bytes_ += result.size();
  e.result = std::move(result);
  finished_.push_back(id);
  std::vector<ReplyTo> replies = std::move(e.replies);
  e.replies.clear();
  evict(now);
  return replies;
}

// Finished entries leave oldest first; `finished_` holds them in that order.
void CommandLog::evict(TimePoint now) {
  while (!finished_.empty()) {
    const auto it = entries_.find(finished_.front());
    const bool too_many = entries_.size() > limits_.max_entries;
    const bool too_big = bytes_ > limits_.max_bytes;
    const bool too_old = it != entries_.end() && now - it->second.at > limits_.max_age;
    if (!too_many && !too_big && !too_old) break;
    if (it != entries_.end()) {
      bytes_ -= it->second.result.size();
      entries_.erase(it);
    }
    finished_.pop_front();
  }
}

}  // namespace lec6::serve
