#include "cli/profile_option.hpp"

#include <fmt/format.h>

#include "cli/app.hpp"

namespace lec6::cli {

twin::FieldProfile profile_option(const std::string& file) {
  if (file.empty()) return {};
  try {
    return twin::load_field_profile(file);
  } catch (const twin::ProfileError& e) {
    throw UsageError(fmt::format("--profile: {}", e.what()));
  }
}

}  // namespace lec6::cli
