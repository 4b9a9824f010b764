#pragma once
// The `history:` section of lec serve's config (docs/history.md).

#include <optional>

#include "config/config_reader.hpp"

namespace lec6::serve::history {

// nullopt when the section is absent or `history: false` (lec serve then
// keeps it in the default directory, or none: ServeConfig::history_off);
// an empty state_dir is the default directory (state_dir.hpp).
std::optional<HistoryConfig> read_history(const Reader& r, const YAML::Node& n);

}  // namespace lec6::serve::history
