#pragma once
// The twin's EEPROM on disk (digest §6 "Memory"): step data, alarm history,
// equipment name and per-step write counters of every controller on the bus.
// Flags, direct-operation data and the state area are RAM and are not kept.
//
// Format: UTF-8 text, one record a line, so a person can read and diff it:
//
//   lec6-twin-state 1
//   controller 1
//   name LEC6-TWIN
//   step 1 writes 2 0001 01F4 0000 3A98 1388 1388 0000 0000 0014 0064 0000 0000 0000 0000 0000 0064
//   alarm 0 34 00 00 00 00 00 00 00
//   end
//
// Steps that are blank and never written, and empty alarm groups, are left out.
// Saving is atomic: a temporary file in the same directory is written and
// fsync'ed, then renamed over the old one (and the directory fsync'ed), so a
// crash leaves either the old or the new file, never a torn one.
//
// Thread safety: the functions share nothing; two saves of the same path at once race (the last
// rename wins, neither file is torn).

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "lec6/expected.hpp"
#include "lec6/sim/controller.hpp"

namespace lec6::sim {

using EepromSet = std::map<uint8_t, Eeprom>;  // by controller ID

std::string serialize_state(const EepromSet& state);
Expected<EepromSet, std::string> parse_state(std::string_view text);

// Writes atomically (temp file + fsync + rename). The error names the path and the cause.
Expected<void, std::string> save_state_file(const std::filesystem::path& path,
                                            const EepromSet& state);

// nullopt when the file does not exist (first start); an error when it
// exists but cannot be read or parsed.
Expected<std::optional<EepromSet>, std::string> load_state_file(const std::filesystem::path& path);

}  // namespace lec6::sim
