#pragma once
// `--profile FILE` of `lec sim` and `lec replay`: the field profile in FILE
// over the default twin (twin::default_profile(): the field's evidence), or over
// the manual's ideal with `--ideal` (twin::ideal_profile()); a file that does
// not load is a usage error naming the option and what is wrong.

#include <string>

#include "lec6/twin/field_profile.hpp"

namespace lec6::cli {

twin::FieldProfile profile_option(const std::string& file, bool ideal = false);

}  // namespace lec6::cli
