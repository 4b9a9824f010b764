#pragma once
// Where lec serve keeps its move history when no --state-dir or
// history.state_dir is given (docs/history.md, "Where it is kept"):
//
//   1. $STATE_DIRECTORY (systemd sets it from the unit's StateDirectory=lec6:
//      /var/lib/lec6; the first one when it lists several),
//   2. $XDG_STATE_HOME/lec6 (an absolute path only, as the XDG spec says),
//   3. $HOME/.local/state/lec6.
//
// nullopt when none applies (no HOME either): the daemon then runs without a
// history and says so. `getenv` is a parameter so tests give their own.
// Thread safety: a pure function of `getenv`.

#include <filesystem>
#include <functional>
#include <optional>
#include <string>

namespace lec6::serve::history {

struct DefaultStateDir {
  std::filesystem::path dir;
  std::string from;  // "$STATE_DIRECTORY", "$XDG_STATE_HOME", "$HOME"
};

using Getenv = std::function<const char*(const char*)>;
std::optional<DefaultStateDir> default_state_dir(const Getenv& getenv);
std::optional<DefaultStateDir> default_state_dir();  // the process' environment

}  // namespace lec6::serve::history
