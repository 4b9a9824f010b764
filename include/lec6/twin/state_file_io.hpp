#pragma once
// The twin's state file on disk (its text: sim/state_file.hpp). Saved with
// transport::write_file_atomically: a crash leaves either the old or the new
// file, never a torn one.
//
// Thread safety: the functions share nothing; saves of one path must not overlap.

#include <filesystem>
#include <optional>
#include <string>

#include "lec6/expected.hpp"
#include "lec6/sim/state_file.hpp"

namespace lec6::twin {

// The error names the path and the cause.
Expected<void, std::string> save_state_file(const std::filesystem::path& path,
                                            const sim::EepromSet& state);

// nullopt when the file does not exist (first start); an error when it
// exists but cannot be read or parsed.
Expected<std::optional<sim::EepromSet>, std::string> load_state_file(
    const std::filesystem::path& path);

}  // namespace lec6::twin
