#pragma once
// `--profile FILE` of `lec sim` and `lec replay`: the field profile in FILE,
// or the defaults when none is given; a file that does not load is a usage
// error naming the option and what is wrong.

#include <string>

#include "lec6/twin/field_profile.hpp"

namespace lec6::cli {

twin::FieldProfile profile_option(const std::string& file);

}  // namespace lec6::cli
