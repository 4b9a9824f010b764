#pragma once
// The `history:` section of lec serve's config (docs/history.md).

#include <optional>

#include "config/config_reader.hpp"

namespace lec6::serve::history {

// nullopt when the section is absent or `history: false`.
std::optional<HistoryConfig> read_history(const Reader& r, const YAML::Node& n);

}  // namespace lec6::serve::history
