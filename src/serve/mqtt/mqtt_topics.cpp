#include "lec6/serve/mqtt_topics.hpp"

#include <fmt/format.h>

namespace lec6::serve {

std::optional<std::string> check_topic_prefix(std::string_view prefix) {
  if (prefix.empty()) return "the topic prefix is empty";
  if (prefix.find_first_of("+#") != std::string_view::npos) {
    return fmt::format("'{}' has a wildcard (+ or #): a prefix is plain topic levels", prefix);
  }
  if (prefix.find('\0') != std::string_view::npos) return "the topic prefix contains NUL";
  if (prefix.front() == '/' || prefix.back() == '/' ||
      prefix.find("//") != std::string_view::npos) {
    return fmt::format("'{}' has an empty topic level (a leading, trailing or double '/')", prefix);
  }
  if (prefix.starts_with("$")) {
    return fmt::format("'{}' starts with '$': those topics belong to the broker", prefix);
  }
  return std::nullopt;
}

MqttTopics::MqttTopics(std::string prefix, std::string bridge)
    : prefix_(std::move(prefix)), bridge_(std::move(bridge)) {}

std::string MqttTopics::status() const {
  return fmt::format("{}/{}/status", prefix_, bridge_);
}

std::string MqttTopics::axis(std::string_view line, std::string_view axis,
                             std::string_view leaf) const {
  return fmt::format("{}/{}/{}/{}", prefix_, line, axis, leaf);
}

std::optional<AxisTopic> MqttTopics::parse(std::string_view topic) const {
  if (!topic.starts_with(prefix_) || topic.size() <= prefix_.size() ||
      topic[prefix_.size()] != '/') {
    return std::nullopt;
  }
  topic.remove_prefix(prefix_.size() + 1);
  AxisTopic t;
  std::string* parts[] = {&t.line, &t.axis, &t.leaf};
  for (std::size_t i = 0; i < 3; ++i) {
    const auto slash = topic.find('/');
    const bool last = i == 2;
    if (last != (slash == std::string_view::npos)) return std::nullopt;
    const auto part = topic.substr(0, slash);
    if (part.empty()) return std::nullopt;
    *parts[i] = std::string(part);
    if (!last) topic.remove_prefix(slash + 1);
  }
  return t;
}

}  // namespace lec6::serve
