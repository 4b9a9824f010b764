#include "state_dir.hpp"

#include <cstdlib>

namespace lec6::serve::history {

std::optional<DefaultStateDir> default_state_dir(const Getenv& getenv) {
  auto var = [&](const char* name) -> std::string {
    const char* v = getenv(name);
    return v ? std::string(v) : std::string();
  };
  if (std::string s = var("STATE_DIRECTORY"); !s.empty()) {
    s = s.substr(0, s.find(':'));
    if (!s.empty()) return DefaultStateDir{s, "$STATE_DIRECTORY"};
  }
  if (const std::string x = var("XDG_STATE_HOME"); !x.empty() && x.front() == '/') {
    return DefaultStateDir{std::filesystem::path(x) / "lec6", "$XDG_STATE_HOME"};
  }
  if (const std::string h = var("HOME"); !h.empty() && h.front() == '/') {
    return DefaultStateDir{std::filesystem::path(h) / ".local" / "state" / "lec6", "$HOME"};
  }
  return std::nullopt;
}

std::optional<DefaultStateDir> default_state_dir() {
  return default_state_dir([](const char* name) { return std::getenv(name); });
}

}  // namespace lec6::serve::history
