#pragma once
// The one set of defaults for the fields a user does not give (issue 27):
// a direct move (client::default_direct_data), a blank step filled field by
// field (`lec step set`, PUT /steps/N, the dashboard, Python's write_step).
// Gentle values, documented in docs/protocol-decisions.md
// ("Direct-operation defaults").
//
// Thread safety: pure.

#include "lec6/lec/step_data.hpp"

namespace lec6::lec {

// ABS, position 0, 100 mm/s, 1000 mm/s² both ways, positioning (pushing
// force and trigger 0), pushing speed 20 mm/s, moving force 100 %, no AREA,
// in position 0.50 mm.
StepData default_step_data();

}  // namespace lec6::lec
