#include "config/config_reader.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "lec6/lec/nearest.hpp"

namespace lec6::serve {

std::optional<std::string> nearest(std::string_view word,
                                   std::initializer_list<const char*> candidates) {
  return lec::nearest(word, std::vector<std::string>(candidates.begin(), candidates.end()));
}

void Reader::fail(const YAML::Node& at, const std::string& path, const std::string& message) const {
  const YAML::Mark mark = at.IsDefined() ? at.Mark() : YAML::Mark::null_mark();
  const std::string where = mark.line >= 0 ? fmt::format("{}:{}", source_, mark.line + 1) : source_;
  throw ConfigError(path.empty() ? fmt::format("{}: {}", where, message)
                                 : fmt::format("{}: {}: {}", where, path, message));
}

void Reader::keys(const YAML::Node& map, const std::string& path,
                  std::initializer_list<const char*> allowed) const {
  if (!map.IsMap()) fail(map, path, "expected a map of settings");
  for (const auto& kv : map) {
    const std::string key = kv.first.as<std::string>();
    if (std::find_if(allowed.begin(), allowed.end(), [&](const char* a) { return key == a; }) !=
        allowed.end()) {
      continue;
    }
    const auto hint = nearest(key, allowed);
    std::string known;
    for (const char* a : allowed) known += (known.empty() ? "" : ", ") + std::string(a);
    fail(kv.first, path.empty() ? key : path + "." + key,
         hint ? fmt::format("unknown key: did you mean '{}'?", *hint)
              : fmt::format("unknown key (known here: {})", known));
  }
}

double Reader::number(const YAML::Node& n, const std::string& path, double fallback, double min,
                      double max) const {
  const double v = get<double>(n, path, fallback);
  if (!std::isfinite(v) || v < min || v > max) {
    fail(n, path, fmt::format("{} is outside {} to {}", n.Scalar(), min, max));
  }
  return v;
}

int64_t Reader::integer(const YAML::Node& n, const std::string& path, int64_t fallback, int64_t min,
                        int64_t max, const std::string& what) const {
  if (!n || n.IsNull()) return fallback;
  int64_t v = 0;
  try {
    v = n.as<int64_t>();
  } catch (const YAML::Exception&) {
    fail(n, path, fmt::format("'{}' is not a whole number ({})", n.Scalar(), what));
  }
  if (v < min || v > max) fail(n, path, fmt::format("{} is not {}", v, what));
  return v;
}

Endpoint Reader::endpoint(const YAML::Node& n, const std::string& path,
                          const std::string& fallback) const {
  const std::string text = get<std::string>(n, path, fallback);
  try {
    return parse_endpoint(text);
  } catch (const ConfigError& e) {
    fail(n, path, e.what());
  }
}

void Reader::name(const YAML::Node& n, const std::string& path, const std::string& value) const {
  if (!n) return;
  const bool ok = !value.empty() && value.size() <= 64 &&
                  std::all_of(value.begin(), value.end(), [](unsigned char c) {
                    return std::isalnum(c) || c == '-' || c == '_';
                  });
  if (!ok) {
    fail(n, path,
         fmt::format("'{}': names are 1 to 64 letters, digits, '-' or '_' (they appear in URLs and "
                     "MQTT topics)",
                     value));
  }
}

}  // namespace lec6::serve
