#pragma once
// Reading one YAML config with messages that name file, line and key
// (private to serve/config*.cpp).

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <initializer_list>
#include <string>

#include "lec6/serve/config.hpp"

namespace lec6::serve {

class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}
  const std::string& source() const { return source_; }

  [[noreturn]] void fail(const YAML::Node& at, const std::string& path,
                         const std::string& message) const;
  // Refuses keys outside `allowed`, suggesting the nearest one.
  void keys(const YAML::Node& map, const std::string& path,
            std::initializer_list<const char*> allowed) const;

  template <typename T>
  T get(const YAML::Node& n, const std::string& path, T fallback) const {
    if (!n || n.IsNull()) return fallback;
    try {
      return n.as<T>();
    } catch (const YAML::Exception&) {
      fail(n, path, fmt::format("'{}' is not {}", n.Scalar(), kind<T>()));
    }
  }
  double number(const YAML::Node& n, const std::string& path, double fallback, double min,
                double max) const;
  int64_t integer(const YAML::Node& n, const std::string& path, int64_t fallback, int64_t min,
                  int64_t max, const std::string& what) const;
  Endpoint endpoint(const YAML::Node& n, const std::string& path,
                    const std::string& fallback) const;
  // Names end up in URLs and MQTT topics: letters, digits, '-' and '_'.
  void name(const YAML::Node& n, const std::string& path, const std::string& value) const;

 private:
  template <typename T>
  static const char* kind() {
    if constexpr (std::is_same_v<T, bool>) return "true or false";
    if constexpr (std::is_same_v<T, std::string>) return "text";
    return "a number";
  }
  std::string source_;
};

// The candidate nearest to `word` by edit distance, if it is close enough to
// be what was meant.
std::optional<std::string> nearest(std::string_view word,
                                   std::initializer_list<const char*> candidates);

}  // namespace lec6::serve
