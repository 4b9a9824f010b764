// Time helpers the test programs share. One definition here, not a copy per
// file: a unity build (LEC6_UNITY) compiles several test files as one, where
// two file-local definitions of the same name clash.
#pragma once

#include "lec6/clock.hpp"

namespace lec6::testing {

// ms(2.5): 2.5 milliseconds as a Duration.
inline Duration ms(double v) {
  return to_duration(FractionalMilliseconds(v));
}

}  // namespace lec6::testing
