#include "cli/profile_option.hpp"

#include <fmt/format.h>

#include "cli/app.hpp"

namespace lec6::cli {

twin::FieldProfile profile_option(const std::string& file, bool ideal) {
  const twin::FieldProfile base = ideal ? twin::ideal_profile() : twin::default_profile();
  if (file.empty()) return base;
  try {
    return twin::load_field_profile(file, base);
  } catch (const twin::ProfileError& e) {
    throw UsageError(fmt::format("--profile: {}", e.what()));
  }
}

}  // namespace lec6::cli
