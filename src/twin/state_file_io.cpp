#include "lec6/twin/state_file_io.hpp"

#include <fmt/format.h>

#include <system_error>

#include "lec6/transport/file.hpp"

namespace lec6::twin {

Expected<void, std::string> save_state_file(const std::filesystem::path& path,
                                            const sim::EepromSet& state) {
  return transport::write_file_atomically(path, sim::serialize_state(state));
}

Expected<std::optional<sim::EepromSet>, std::string> load_state_file(
    const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    if (ec) return unexpected(fmt::format("cannot check {}: {}", path.string(), ec.message()));
    return std::optional<sim::EepromSet>{};
  }
  auto text = transport::read_file(path);
  if (!text) return unexpected(text.error());
  auto parsed = sim::parse_state(*text);
  if (!parsed) return unexpected(fmt::format("{}: {}", path.string(), parsed.error()));
  return std::optional<sim::EepromSet>(std::move(*parsed));
}

}  // namespace lec6::twin
